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

/// The Pareto front (`front`, from [`pareto_front`]) as the red line the plots draw: its
/// points (cost, error) in order of cost.
fn front_line(points: &[(String, f64, f64)], front: &[bool]) -> LineSeries<BitMapBackend<'static>, (f64, f64)> {
    let mut line: Vec<(f64, f64)> = points.iter().zip(front).filter(|(_, f)| **f).map(|(p, _)| (p.1, p.2)).collect();
    line.sort_by(|a, b| a.0.total_cmp(&b.0));
    LineSeries::new(line, RGBColor(200, 60, 60).stroke_width(2))
}

/// Points on the Pareto front (no other point is both cheaper and more accurate). The
/// `oracle` is a bound whose cost excludes its ray tracing, so it neither sits on nor
/// shapes the front.
pub fn pareto_front(points: &[(String, f64, f64)]) -> Vec<bool> {
    let real = |name: &str| !crate::eval::is_bound(name);
    points
        .iter()
        .map(|(n, c, e)| {
            real(n) && !points.iter().any(|(n2, c2, e2)| real(n2) && ((c2 <= c && e2 < e) || (c2 < c && e2 <= e)))
        })
        .collect()
}

/// A tick label that fits its axis whatever the magnitude: plain for 0.001 ≤ |v| < 10⁴,
/// scientific (`1.2e10`) otherwise.
#[must_use]
pub fn tick(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !(1e-3..1e4).contains(&a) {
        format!("{v:.1e}")
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

/// Labels for markers at pixel positions, placed so that no two overlap (as far as the
/// candidates allow) and none leaves `area`: markers closer than 5 px share one label
/// (`a = b`), and each label tries positions around its marker in turn. Returns (text,
/// top-left pixel) per label. `char_px` is the font's mean advance.
pub fn place_labels(
    markers: &[(String, (i32, i32))],
    area: ((i32, i32), (i32, i32)),
    char_px: f64,
    line_px: i32,
) -> Vec<(String, (i32, i32))> {
    // merge markers at (nearly) the same place
    let mut groups: Vec<(String, (i32, i32))> = Vec::new();
    for (name, p) in markers {
        match groups.iter_mut().find(|(_, q)| (q.0 - p.0).abs() <= 5 && (q.1 - p.1).abs() <= 5) {
            Some(g) => g.0 = format!("{} = {name}", g.0),
            None => groups.push((name.clone(), *p)),
        }
    }
    let marker_boxes: Vec<((i32, i32), (i32, i32))> =
        markers.iter().map(|(_, p)| ((p.0 - 5, p.1 - 5), (p.0 + 5, p.1 + 5))).collect();
    let overlaps = |a: ((i32, i32), (i32, i32)), b: ((i32, i32), (i32, i32))| {
        a.0.0 < b.1.0 && b.0.0 < a.1.0 && a.0.1 < b.1.1 && b.0.1 < a.1.1
    };
    let inside =
        |b: ((i32, i32), (i32, i32))| b.0.0 >= area.0.0 && b.0.1 >= area.0.1 && b.1.0 <= area.1.0 && b.1.1 <= area.1.1;
    let mut placed: Vec<((i32, i32), (i32, i32))> = Vec::new();
    let mut out = Vec::new();
    for (text, (x, y)) in groups {
        let w = (text.chars().count() as f64 * char_px).ceil() as i32;
        let h = line_px;
        let candidates = [
            (8, -h / 2 - 6),
            (8, -h / 2 + 8),
            (-w - 8, -h / 2 - 6),
            (-w - 8, -h / 2 + 8),
            (-w / 2, -h - 8),
            (-w / 2, 8),
            (8, -h - 14),
            (8, 14),
            (-w - 8, -h - 14),
            (-w - 8, 14),
            (-w / 2, -2 * h - 10),
            (-w / 2, h + 12),
        ];
        let boxes = candidates.map(|(dx, dy)| ((x + dx, y + dy), (x + dx + w, y + dy + h)));
        let free = |b: &((i32, i32), (i32, i32))| {
            inside(*b)
                && !placed.iter().any(|p| overlaps(*p, *b))
                && !marker_boxes.iter().any(|m| overlaps(*m, *b) && !(m.0.0 + 5 == x && m.0.1 + 5 == y))
        };
        let chosen =
            boxes.iter().find(|b| free(b)).or_else(|| boxes.iter().find(|b| inside(**b))).copied().unwrap_or(boxes[0]);
        placed.push(chosen);
        out.push((text, chosen.0));
    }
    out
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

/// Log-log scatter of (cost ns/lookup, error) per method, Pareto front marked, labels placed
/// without overlaps (markers at one place share a label).
pub fn error_vs_cost(path: &Path, title: &str, y_desc: &str, points: &[(String, f64, f64)]) -> Result<(), FileError> {
    register_font();
    let (w, h) = (960u32, 640u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
        // the per-query bounds (best-aim, best-fetch) cost a search, not a lookup: drawn as
        // horizontal lines, their cost kept off the axis
        let is_line = |name: &str| crate::eval::bound::is_search(name);
        let lines: Vec<&(String, f64, f64)> =
            points.iter().filter(|p| is_line(&p.0) && p.2 > 0.0 && p.2.is_finite()).collect();
        let points: Vec<(String, f64, f64)> = points.iter().filter(|p| !is_line(&p.0)).cloned().collect();
        let points = points.as_slice();
        let finite: Vec<&(String, f64, f64)> =
            points.iter().filter(|p| p.1 > 0.0 && p.2 > 0.0 && p.1.is_finite() && p.2.is_finite()).collect();
        let (cmin, cmax) = finite.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
        let (emin, emax) =
            finite.iter().chain(&lines).fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.2), b.max(p.2)));
        let (cmin, cmax) = if finite.is_empty() { (1.0, 10.0) } else { (cmin / 1.6, cmax * 1.6) };
        let (emin, emax) = if finite.is_empty() { (0.01, 1.0) } else { (emin / 1.3, emax * 1.3) };
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{title} (red: Pareto front; hollow, grey: bounds)"), ("sans-serif", 22))
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
            .y_desc(y_desc)
            .label_style(("sans-serif", 15))
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()
            .map_err(|e| plot_err(path, e))?;
        for (name, _, e) in &lines {
            chart
                .draw_series(LineSeries::new([(cmin, *e), (cmax, *e)], RGBColor(150, 150, 150).stroke_width(1)))
                .map_err(|e| plot_err(path, e))?;
            let (x, y) = chart.backend_coord(&(cmin, *e));
            root.draw(&Text::new(
                format!("{name} (per-query search)"),
                (x + 6, y - 18),
                ("sans-serif", 14).into_font().color(&RGBColor(110, 110, 110)),
            ))
            .map_err(|e| plot_err(path, e))?;
        }
        let front = pareto_front(points);
        chart.draw_series(front_line(points, &front)).map_err(|e| plot_err(path, e))?;
        let mut markers = Vec::new();
        for ((name, c, e), on_front) in points.iter().zip(&front) {
            if !(*c > 0.0 && *e > 0.0 && c.is_finite() && e.is_finite()) {
                continue;
            }
            let color = if *on_front { RGBColor(200, 40, 40) } else { RGBColor(40, 70, 160) };
            let style =
                if crate::eval::is_bound(name) { RGBColor(120, 120, 120).stroke_width(2) } else { color.filled() };
            chart.draw_series(std::iter::once(Circle::new((*c, *e), 5, style))).map_err(|e| plot_err(path, e))?;
            markers.push((name.clone(), chart.backend_coord(&(*c, *e))));
        }
        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let area = ((xr.start, yr.start), (xr.end, yr.end));
        for (text, at) in place_labels(&markers, area, 8.4, 16) {
            root.draw(&Text::new(text, at, ("sans-serif", 15).into_font().color(&BLACK)))
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
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
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
            // the per-query bounds cost a search, not a lookup: left out of the panels
            let points: Vec<(String, f64, f64)> =
                points.iter().filter(|p| !crate::eval::bound::is_search(&p.0)).cloned().collect();
            let points = points.as_slice();
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
                .x_label_formatter(&|v| tick(*v))
                .y_label_formatter(&|v| tick(*v))
                .draw()
                .map_err(|e| plot_err(path, e))?;
            let front = pareto_front(points);
            chart.draw_series(front_line(points, &front)).map_err(|e| plot_err(path, e))?;
            let mut markers = Vec::new();
            for ((label, c, e), on_front) in points.iter().zip(&front) {
                if !(*c > 0.0 && e.is_finite()) {
                    continue;
                }
                let runtime = crate::eval::RowId::parse(label) == Some(crate::eval::RowId::RUNTIME);
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
                    markers.push((label.clone(), chart.backend_coord(&(*c, *e))));
                }
            }
            let (xr, yr) = chart.plotting_area().get_pixel_range();
            // marker and label positions are the backend's pixels: drawn on the root
            for (text, at) in place_labels(&markers, ((xr.start, yr.start), (xr.end, yr.end)), 6.8, 13) {
                root.draw(&Text::new(text, at, ("sans-serif", 12).into_font().color(&BLACK)))
                    .map_err(|e| plot_err(path, e))?;
            }
        }
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::preview::write_png(path, w, h, &buf)
}

/// One horizontal slice of the grid for [`heatmap_slices`]: its title and, per cell (x
/// fastest, then z), a value in [0, 1] or `None` (drawn black: no value there).
pub struct Slice {
    pub title: String,
    pub nx: usize,
    pub nz: usize,
    pub values: Vec<Option<f64>>,
    /// Cells that keep the fallback (drawn grey whatever their value).
    pub fallback: Vec<bool>,
}

/// The colour of value `t` in [0, 1]: light grey (0) to saturated green (1).
fn improvement_colour(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0);
    RGBColor(
        (200.0 * (1.0 - t) + 20.0 * t) as u8,
        (200.0 * (1.0 - t) + 150.0 * t) as u8,
        (200.0 * (1.0 - t) + 60.0 * t) as u8,
    )
}

/// Grid slices as heat maps, four to a row, each with its cell axes (x to the right, z
/// up), and a colour bar: `legend` names what the colour measures.
pub fn heatmap_slices(path: &Path, title: &str, legend: &str, slices: &[Slice]) -> Result<(), FileError> {
    register_font();
    let cols = 4usize.min(slices.len().max(1));
    let rows = slices.len().div_ceil(cols).max(1);
    let (pw, ph) = (260u32, 260u32);
    let (w, h) = ((pw * cols as u32).max(900), ph * rows as u32 + 110);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
        root.draw(&Text::new(title.to_string(), (10, 8), ("sans-serif", 18).into_font().color(&BLACK)))
            .map_err(|e| plot_err(path, e))?;
        let body = root.margin(36, 74, 0, 0);
        let panels = body.split_evenly((rows, cols));
        for (s, area) in slices.iter().zip(panels.iter()) {
            let mut chart = ChartBuilder::on(area)
                .caption(&s.title, ("sans-serif", 14))
                .margin(6)
                .x_label_area_size(30)
                .y_label_area_size(34)
                .build_cartesian_2d(0f64..s.nx as f64, 0f64..s.nz as f64)
                .map_err(|e| plot_err(path, e))?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc("cell x")
                .y_desc("cell z")
                .x_labels(s.nx.min(6))
                .y_labels(s.nz.min(6))
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| format!("{v:.0}"))
                .label_style(("sans-serif", 11))
                .draw()
                .map_err(|e| plot_err(path, e))?;
            chart
                .draw_series((0..s.nx * s.nz).map(|k| {
                    let (x, z) = ((k % s.nx) as f64, (k / s.nx) as f64);
                    let colour = match (s.values[k], s.fallback[k]) {
                        (None, _) => BLACK,
                        (Some(_), true) => RGBColor(150, 150, 150),
                        (Some(v), false) => improvement_colour(v),
                    };
                    Rectangle::new([(x, z), (x + 1.0, z + 1.0)], colour.filled())
                }))
                .map_err(|e| plot_err(path, e))?;
        }
        // the colour bar and the key
        let (bx, by, bw, bh) = (40i32, h as i32 - 60, 300i32, 16i32);
        for i in 0..bw {
            let c = improvement_colour(i as f64 / (bw - 1) as f64);
            root.draw(&Rectangle::new([(bx + i, by), (bx + i + 1, by + bh)], c.filled()))
                .map_err(|e| plot_err(path, e))?;
        }
        let small = ("sans-serif", 12).into_font().color(&BLACK);
        for (t, label) in [(0.0, "0%"), (0.5, "50%"), (1.0, "100%")] {
            let x = bx + (t * (bw - 1) as f64) as i32;
            root.draw(&Text::new(label.to_string(), (x - 8, by + bh + 4), small.clone()))
                .map_err(|e| plot_err(path, e))?;
        }
        root.draw(&Text::new(legend.to_string(), (bx, by - 18), small.clone())).map_err(|e| plot_err(path, e))?;
        let kx = bx + bw + 40;
        root.draw(&Rectangle::new([(kx, by), (kx + 16, by + bh)], RGBColor(150, 150, 150).filled()))
            .map_err(|e| plot_err(path, e))?;
        root.draw(&Text::new("keeps the fallback".to_string(), (kx + 22, by + 2), small.clone()))
            .map_err(|e| plot_err(path, e))?;
        root.draw(&Rectangle::new([(kx + 170, by), (kx + 186, by + bh)], BLACK.filled()))
            .map_err(|e| plot_err(path, e))?;
        root.draw(&Text::new("inside geometry (not fitted)".to_string(), (kx + 192, by + 2), small))
            .map_err(|e| plot_err(path, e))?;
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::preview::write_png(path, w, h, &buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_never_overlap_and_stay_in_the_plot() {
        // a crowd: near-equal points, a pair at one place, huge objectives
        let markers: Vec<(String, (i32, i32))> = [
            ("fitted", (300, 300)),
            ("runtime", (301, 300)),
            ("fitted-L2-all", (305, 292)),
            ("fitted-trilinear", (320, 288)),
            ("celldepth", (310, 280)),
            ("kdop", (298, 284)),
            ("none", (100, 100)),
        ]
        .iter()
        .map(|(n, p)| (n.to_string(), *p))
        .collect();
        let area = ((80, 60), (900, 560));
        let placed = place_labels(&markers, area, 8.4, 16);
        assert_eq!(placed.len(), 6, "fitted and runtime share a label");
        assert!(placed.iter().any(|(t, _)| t == "fitted = runtime"));
        let boxes: Vec<_> = placed
            .iter()
            .map(|(t, (x, y))| ((*x, *y), (*x + (t.chars().count() as f64 * 8.4).ceil() as i32, *y + 16)))
            .collect();
        for (i, a) in boxes.iter().enumerate() {
            assert!(
                a.0.0 >= area.0.0 && a.1.0 <= area.1.0 && a.0.1 >= area.0.1 && a.1.1 <= area.1.1,
                "{:?}",
                placed[i]
            );
            for b in &boxes[i + 1..] {
                let overlap = a.0.0 < b.1.0 && b.0.0 < a.1.0 && a.0.1 < b.1.1 && b.0.1 < a.1.1;
                assert!(!overlap, "{a:?} and {b:?} overlap");
            }
        }
        // tick labels stay short at any magnitude
        for v in [2.3e10, 1e-7, 12345.0, 0.5, 3.0, 250.0] {
            assert!(tick(v).len() <= 8, "{v}: {}", tick(v));
        }
    }
}
