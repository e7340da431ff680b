//! The log-log plot of relMSE against time (or samples) for `caustica bench`, PNG and SVG.

use super::Checkpoint;
use caustica::scene::{IntegratorKind, LightSelection};
use caustica::{Error, Result};
use plotters::coord::Shift;
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
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, crate::density_plot::FONT);
    if path.extension().is_some_and(|e| e == "svg") {
        let root = SVGBackend::new(path, SIZE).into_drawing_area();
        draw(&root, checkpoints, series, by_samples).map_err(fail)?;
        root.present().map_err(|e| fail(e.to_string()))
    } else {
        let mut buffer = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buffer, SIZE).into_drawing_area();
            draw(&root, checkpoints, series, by_samples).map_err(fail)?;
            root.present().map_err(|e| fail(e.to_string()))?;
        }
        image::RgbImage::from_raw(SIZE.0, SIZE.1, buffer)
            .ok_or_else(|| fail("buffer size".into()))?
            .save(path)
            .map_err(|e| fail(e.to_string()))
    }
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
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| e.to_string())?;
    chart.configure_mesh().x_desc(x_label).y_desc("relMSE").draw().map_err(|e| e.to_string())?;
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
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())
}
