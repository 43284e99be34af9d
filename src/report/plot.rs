//! Plots (plotters, bitmap backend, pure-Rust text with a shipped font). Without a
//! registered font plotters silently draws no text, so the font is registered here once.

use crate::files::FileError;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The font is compiled in; failure would be a build defect, and text is then absent.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

fn plot_err(path: &Path, e: impl std::fmt::Display) -> FileError {
    FileError::Invalid { path: path.to_path_buf(), field: "plot".into(), message: e.to_string() }
}

/// Points on the Pareto front (no other point is both cheaper and more accurate). The
/// `oracle` is a bound whose cost excludes its ray tracing, so it neither sits on nor
/// shapes the front.
pub fn pareto_front(points: &[(String, f64, f64)]) -> Vec<bool> {
    let real = |name: &str| name != "oracle";
    points
        .iter()
        .map(|(n, c, e)| {
            real(n) && !points.iter().any(|(n2, c2, e2)| real(n2) && ((c2 <= c && e2 < e) || (c2 < c && e2 <= e)))
        })
        .collect()
}

/// 1-2-5 tick values covering [lo, hi].
fn ticks_125(lo: f64, hi: f64) -> Vec<f64> {
    // a non-finite, non-positive or absurd range gets no ticks (it would never end)
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo && hi / lo < 1e30) {
        return Vec::new();
    }
    let mut out = Vec::new();
    let mut decade = libm::pow(10f64, libm::log10(lo).floor());
    while decade <= hi {
        for m in [1.0, 2.0, 5.0] {
            let v = decade * m;
            if v >= lo && v <= hi {
                out.push(v);
            }
        }
        decade *= 10.0;
    }
    if out.len() < 3 {
        // narrow range: 6 evenly spaced (in log) ticks
        out = (0..6).map(|k| lo * libm::pow(hi / lo, k as f64 / 5.0)).collect();
    }
    out
}

/// Log-log scatter of (cost ns/lookup, relative RMSE) per method, Pareto front marked.
pub fn error_vs_cost(path: &Path, title: &str, points: &[(String, f64, f64)]) -> Result<(), FileError> {
    register_font();
    let (w, h) = (960u32, 640u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
        let finite: Vec<&(String, f64, f64)> =
            points.iter().filter(|p| p.1 > 0.0 && p.2 > 0.0 && p.1.is_finite() && p.2.is_finite()).collect();
        let (cmin, cmax) = finite.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
        let (emin, emax) = finite.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.2), b.max(p.2)));
        let (cmin, cmax) = if finite.is_empty() { (1.0, 10.0) } else { (cmin / 1.6, cmax * 1.6) };
        let (emin, emax) = if finite.is_empty() { (0.01, 1.0) } else { (emin / 1.3, emax * 1.3) };
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{title} (red: Pareto front; hollow: oracle bound)"), ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d(
                (cmin..cmax).log_scale().with_key_points(ticks_125(cmin, cmax)),
                (emin..emax).log_scale().with_key_points(ticks_125(emin, emax)),
            )
            .map_err(|e| plot_err(path, e))?;
        chart
            .configure_mesh()
            .x_desc("cost (ns per lookup, single thread, log)")
            .y_desc("relative RMSE (log)")
            .label_style(("sans-serif", 15))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| {
                if *v >= 1.0 { format!("{v:.2}") } else { format!("{v:.3}") }
            })
            .draw()
            .map_err(|e| plot_err(path, e))?;
        let front = pareto_front(points);
        let mut front_pts: Vec<(f64, f64)> =
            points.iter().zip(&front).filter(|(_, f)| **f).map(|(p, _)| (p.1, p.2)).collect();
        front_pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(front_pts, RGBColor(200, 60, 60).stroke_width(2)))
            .map_err(|e| plot_err(path, e))?;
        for ((name, c, e), on_front) in points.iter().zip(&front) {
            if !(*c > 0.0 && *e > 0.0) {
                continue;
            }
            let color = if *on_front { RGBColor(200, 40, 40) } else { RGBColor(40, 70, 160) };
            let style = if name == "oracle" { RGBColor(120, 120, 120).stroke_width(2) } else { color.filled() };
            chart.draw_series(std::iter::once(Circle::new((*c, *e), 5, style))).map_err(|e| plot_err(path, e))?;
            chart
                .draw_series(std::iter::once(Text::new(
                    name.clone(),
                    (*c * 1.06, *e * 1.02),
                    ("sans-serif", 15).into_font().color(&BLACK),
                )))
                .map_err(|e| plot_err(path, e))?;
        }
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::preview::write_png(path, w, h, &buf)
}

/// Line plot of named series (linear axes), for convergence curves.
pub fn line_plot(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[(String, Vec<(f64, f64)>)],
) -> Result<(), FileError> {
    register_font();
    let (w, h) = (900u32, 560u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
        let pts = series.iter().flat_map(|(_, p)| p.iter()).filter(|p| p.0.is_finite() && p.1.is_finite());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for p in pts {
            x0 = x0.min(p.0);
            x1 = x1.max(p.0);
            y0 = y0.min(p.1);
            y1 = y1.max(p.1);
        }
        if !(x1 > x0) {
            (x0, x1) = (0.0, 1.0);
        }
        if !(y1 > y0) {
            (y0, y1) = (y0.min(0.0), y0.max(0.0) + 1.0);
        }
        let pad = (y1 - y0) * 0.08;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d(x0..x1 * 1.02, (y0 - pad)..(y1 + pad))
            .map_err(|e| plot_err(path, e))?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| plot_err(path, e))?;
        let colours = [
            RGBColor(200, 40, 40),
            RGBColor(240, 140, 130),
            RGBColor(40, 70, 160),
            RGBColor(130, 160, 230),
            RGBColor(40, 140, 60),
            RGBColor(140, 210, 140),
            RGBColor(140, 90, 20),
            RGBColor(220, 180, 110),
        ];
        for (k, (name, points)) in series.iter().enumerate() {
            let c = colours[k % colours.len()];
            chart
                .draw_series(LineSeries::new(points.clone(), c.stroke_width(2)))
                .map_err(|e| plot_err(path, e))?
                .label(name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
            chart.draw_series(points.iter().map(|p| Circle::new(*p, 4, c.filled()))).map_err(|e| plot_err(path, e))?;
        }
        chart
            .configure_series_labels()
            .label_font(("sans-serif", 15))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| plot_err(path, e))?;
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::preview::write_png(path, w, h, &buf)
}

/// Side-by-side octahedral views (one labelled tile per entry), tone-mapped with one
/// common exposure so brightness compares across tiles.
pub fn views(path: &Path, title: &str, tiles: &[(String, crate::octa::OctMap<glam::Vec3>)]) -> Result<(), FileError> {
    register_font();
    let Some(res) = tiles.first().map(|t| t.1.res as usize) else { return Ok(()) };
    let (pad, label_h, title_h) = (8usize, 22usize, 30usize);
    let (w, h) = (tiles.len() * (res + pad) + pad, title_h + label_h + res + pad);
    let mut buf = vec![255u8; w * h * 3];
    let all: Vec<glam::Vec3> = tiles.iter().flat_map(|t| t.1.texels.iter().copied()).collect();
    let exposure = crate::tonemap::key_exposure(&all);
    for (k, (_, map)) in tiles.iter().enumerate() {
        let rgb = crate::tonemap::to_srgb8(&map.texels, exposure);
        let x0 = pad + k * (res + pad);
        for j in 0..res {
            for i in 0..res {
                let src = (j * res + i) * 3;
                let dst = ((title_h + label_h + j) * w + x0 + i) * 3;
                buf[dst..dst + 3].copy_from_slice(&rgb[src..src + 3]);
            }
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w as u32, h as u32)).into_drawing_area();
        let style = ("sans-serif", 16).into_font().color(&BLACK);
        root.draw(&Text::new(title.to_string(), (pad as i32, 6), ("sans-serif", 18).into_font().color(&BLACK)))
            .map_err(|e| plot_err(path, e))?;
        for (k, (name, _)) in tiles.iter().enumerate() {
            let x0 = (pad + k * (res + pad)) as i32;
            root.draw(&Text::new(name.clone(), (x0, (title_h + 2) as i32), style.clone()))
                .map_err(|e| plot_err(path, e))?;
        }
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::preview::write_png(path, w as u32, h as u32, &buf)
}

/// One tile of an image grid: label and 8-bit RGB pixels of `width × height`.
pub struct Tile {
    pub label: String,
    pub rgb: Vec<u8>,
    pub width: usize,
    pub height: usize,
}

impl Tile {
    /// The tile enlarged `k` times, nearest neighbour (pixels stay pixels).
    #[must_use]
    pub fn enlarged(self, k: usize) -> Tile {
        let (w, h) = (self.width * k, self.height * k);
        let mut rgb = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                let src = ((y / k) * self.width + x / k) * 3;
                if src + 3 <= self.rgb.len() {
                    rgb[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&self.rgb[src..src + 3]);
                }
            }
        }
        Tile { label: self.label, rgb, width: w, height: h }
    }
}

/// Rows of labelled image tiles under a title (each row as tall as its tallest tile).
pub fn image_grid(path: &Path, title: &str, rows: &[Vec<Tile>]) -> Result<(), FileError> {
    register_font();
    let (pad, label_h, title_h) = (8usize, 20usize, 30usize);
    let row_h: Vec<usize> = rows.iter().map(|r| r.iter().map(|t| t.height).max().unwrap_or(0)).collect();
    let w = rows.iter().map(|r| r.iter().map(|t| t.width + pad).sum::<usize>() + pad).max().unwrap_or(pad).max(480);
    let h = title_h + row_h.iter().map(|rh| rh + label_h + pad).sum::<usize>();
    let mut buf = vec![255u8; w * h * 3];
    let mut y0 = title_h;
    let mut labels = Vec::new();
    for (row, rh) in rows.iter().zip(&row_h) {
        let mut x0 = pad;
        for t in row {
            labels.push((t.label.clone(), x0, y0));
            for j in 0..t.height {
                for i in 0..t.width {
                    let (src, dst) = ((j * t.width + i) * 3, ((y0 + label_h + j) * w + x0 + i) * 3);
                    if src + 3 <= t.rgb.len() && dst + 3 <= buf.len() {
                        buf[dst..dst + 3].copy_from_slice(&t.rgb[src..src + 3]);
                    }
                }
            }
            x0 += t.width + pad;
        }
        y0 += rh + label_h + pad;
    }
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w as u32, h as u32)).into_drawing_area();
        root.draw(&Text::new(title.to_string(), (pad as i32, 6), ("sans-serif", 17).into_font().color(&BLACK)))
            .map_err(|e| plot_err(path, e))?;
        let style = ("sans-serif", 14).into_font().color(&BLACK);
        for (label, x, y) in labels {
            root.draw(&Text::new(label, (x as i32, (y + 2) as i32), style.clone())).map_err(|e| plot_err(path, e))?;
        }
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::preview::write_png(path, w as u32, h as u32, &buf)
}

/// A scatter panel: its title and its points (row label, cost in ns per lookup, error).
pub type Panel = (String, Vec<(String, f64, f64)>);

/// Small log-x scatter panels of (cost ns/lookup, error) per row, one per entry of
/// `panels` (title, points), three to a line. Each panel labels its Pareto front and the
/// `runtime` row; the front is drawn red.
pub fn error_vs_cost_panels(path: &Path, title: &str, y_desc: &str, panels: &[Panel]) -> Result<(), FileError> {
    register_font();
    let cols = 3usize;
    let lines = panels.len().div_ceil(cols).max(1);
    let (pw, ph) = (520u32, 400u32);
    let (w, h) = (pw * cols as u32, ph * lines as u32 + 40);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
        root.draw(&Text::new(title.to_string(), (12, 10), ("sans-serif", 20).into_font().color(&BLACK)))
            .map_err(|e| plot_err(path, e))?;
        let body = root.margin(40, 0, 0, 0);
        let areas = body.split_evenly((lines, cols));
        for ((name, points), area) in panels.iter().zip(areas) {
            let finite: Vec<&(String, f64, f64)> =
                points.iter().filter(|p| p.1 > 0.0 && p.2 >= 0.0 && p.1.is_finite() && p.2.is_finite()).collect();
            let (cmin, cmax) = finite.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
            let (emin, emax) = finite.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.2), b.max(p.2)));
            let (cmin, cmax) = if finite.is_empty() { (1.0, 10.0) } else { (cmin / 1.4, cmax * 1.4) };
            let (emin, emax) = if finite.is_empty() { (0.0, 1.0) } else { (emin * 0.9, emax * 1.08) };
            let mut chart = ChartBuilder::on(&area)
                .caption(name.clone(), ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(58)
                .build_cartesian_2d((cmin..cmax).log_scale().with_key_points(ticks_125(cmin, cmax)), emin..emax)
                .map_err(|e| plot_err(path, e))?;
            chart
                .configure_mesh()
                .x_desc("ns per lookup (log)")
                .y_desc(y_desc)
                .label_style(("sans-serif", 12))
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| format!("{v:.3}"))
                .draw()
                .map_err(|e| plot_err(path, e))?;
            let front = pareto_front(points);
            let mut front_pts: Vec<(f64, f64)> =
                points.iter().zip(&front).filter(|(_, f)| **f).map(|(p, _)| (p.1, p.2)).collect();
            front_pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(front_pts, RGBColor(200, 60, 60).stroke_width(2)))
                .map_err(|e| plot_err(path, e))?;
            for ((label, c, e), on_front) in points.iter().zip(&front) {
                if !(*c > 0.0 && e.is_finite()) {
                    continue;
                }
                let runtime = label == "runtime";
                let color = if runtime {
                    RGBColor(20, 140, 40)
                } else if *on_front {
                    RGBColor(200, 40, 40)
                } else {
                    RGBColor(110, 130, 180)
                };
                let size = if runtime || *on_front { 5 } else { 3 };
                chart
                    .draw_series(std::iter::once(Circle::new((*c, *e), size, color.filled())))
                    .map_err(|e| plot_err(path, e))?;
                if runtime || *on_front {
                    chart
                        .draw_series(std::iter::once(Text::new(
                            label.clone(),
                            (*c * 1.05, *e),
                            ("sans-serif", 12).into_font().color(&BLACK),
                        )))
                        .map_err(|e| plot_err(path, e))?;
                }
            }
        }
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::preview::write_png(path, w, h, &buf)
}
