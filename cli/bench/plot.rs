//! The log-log plot of relMSE against time (or samples) for `caustica bench`, PNG and SVG.

use super::Checkpoint;
use caustica::scene::{IntegratorKind, LightSelection};
use caustica::{Error, Result};
use plotters::coord::Shift;
use plotters::coord::combinators::{LogCoord, WithKeyPoints};
use plotters::prelude::*;
use std::path::Path;

const SIZE: (u32, u32) = (900, 560);

/// One plotted line: integrator, light selection, label.
pub type Series = (IntegratorKind, LightSelection, String);

/// Draw one line per series into `path` (.png or .svg).
pub fn write_plot(
    path: &Path,
    checkpoints: &[Checkpoint],
    series: &[Series],
    by_samples: bool,
) -> Result<()> {
    let fail = |e: String| Error::Output { path: path.into(), message: format!("plotting failed: {e}") };
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, crate::plot_text::FONT);
    if path.extension().is_some_and(|e| e == "svg") {
        let root = SVGBackend::new(path, SIZE).into_drawing_area();
        draw(&root, checkpoints, series, by_samples).map_err(fail)?;
        root.present().map_err(|e| fail(e.to_string()))
    } else {
        let mut buffer = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
        {
            let root = crate::plot_text::GlyphText::new(BitMapBackend::with_buffer(&mut buffer, SIZE))
                .into_drawing_area();
            draw(&root, checkpoints, series, by_samples).map_err(fail)?;
            root.present().map_err(|e| fail(e.to_string()))?;
        }
        image::RgbImage::from_raw(SIZE.0, SIZE.1, buffer)
            .ok_or_else(|| fail("buffer size".into()))?
            .save(path)
            .map_err(|e| fail(e.to_string()))
    }
}

/// A log axis labelled at 1, 2 and 5 times powers of ten (only the powers when it spans more than
/// three decades), with light lines at every integer multiple.
fn log_axis(lo: f64, hi: f64) -> WithKeyPoints<LogCoord<f64>> {
    let decades = (lo.log10().floor() as i32)..=(hi.log10().ceil() as i32);
    let at = |multiples: &[f64]| -> Vec<f64> {
        let within = |v: &f64| (lo..=hi).contains(v);
        decades
            .clone()
            .flat_map(|d| multiples.iter().map(move |k| k * 10f64.powi(d)))
            .filter(within)
            .collect()
    };
    let labelled = at(if hi / lo > 1e3 { &[1.0] } else { &[1.0, 2.0, 5.0] });
    let every = at(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    (lo..hi).log_scale().with_key_points(labelled).with_light_points(every)
}

/// A tick label in at most three significant digits, without trailing zeros; powers of ten beyond
/// [0.001, 10000) in exponent form.
fn tick(value: f64) -> String {
    if !(value > 0.0 && value.is_finite()) {
        return format!("{value}");
    }
    let exponent = value.log10().floor();
    if !(-3.0..4.0).contains(&exponent) {
        return format!("{value:.0e}");
    }
    let decimals = (2.0 - exponent).max(0.0) as usize;
    let text = format!("{value:.decimals$}");
    if text.contains('.') { text.trim_end_matches('0').trim_end_matches('.').to_string() } else { text }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    checkpoints: &[Checkpoint],
    series: &[Series],
    by_samples: bool,
) -> std::result::Result<(), String> {
    let x_of = |c: &Checkpoint| if by_samples { c.samples_or_passes } else { c.seconds };
    let points: Vec<(f64, f64)> = checkpoints
        .iter()
        .map(|c| (x_of(c), c.relmse))
        .filter(|&(x, y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    let range = |values: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
        if lo.is_finite() { (lo / 1.5, hi * 1.5) } else { (0.1, 10.0) }
    };
    let (x0, x1) = range(&mut points.iter().map(|p| p.0));
    let (y0, y1) = range(&mut points.iter().map(|p| p.1));
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let x_label = if by_samples { "samples per pixel / passes" } else { "seconds" };
    let mut chart = ChartBuilder::on(root)
        .caption(format!("relMSE against {x_label}"), ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(log_axis(x0, x1), log_axis(y0, y1))
        .map_err(|e| e.to_string())?;
    // Labels printed short: plotters' defaults print log-axis labels at full f64 precision
    // ("0.30000000000000004"), which overlapped into an unreadable band.
    chart
        .configure_mesh()
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(BLACK.mix(0.04))
        .bold_line_style(BLACK.mix(0.15))
        .x_desc(x_label)
        .y_desc("relMSE")
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, (kind, selection, label)) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let line: Vec<(f64, f64)> = checkpoints
            .iter()
            .filter(|c| c.integrator == *kind && c.light_selection == *selection && c.relmse > 0.0)
            .map(|c| (x_of(c), c.relmse))
            .collect();
        chart
            .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
        chart
            .draw_series(line.iter().map(|&p| Circle::new(p, 3, color.filled())))
            .map_err(|e| e.to_string())?;
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 15))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::tick;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick(0.30000000000000004), "0.3");
        assert_eq!(tick(0.001), "0.001");
        assert_eq!(tick(2.0), "2");
        assert_eq!(tick(12.5), "12.5");
        assert_eq!(tick(1500.0), "1500");
        assert_eq!(tick(0.00012), "1e-4");
        assert_eq!(tick(60000.0), "6e4");
    }
}
