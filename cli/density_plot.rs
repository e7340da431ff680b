//! `caustica density`: read numbers, estimate their density, and draw the estimate over the data (a
//! rug of the points, and the bars for a histogram) as a PNG.

use crate::args::{DensityArgs, DensityMethod};
use caustica::density::bandwidth::{least_squares_cv, silverman};
use caustica::density::data::read_data;
use caustica::density::{Histogram, KernelEstimate, KnnEstimate, Sample, VariableKernel};
use caustica::{Error, Result};
use plotters::prelude::*;
use std::path::Path;

/// Plot size in pixels.
const SIZE: (u32, u32) = (800, 500);
/// Points at which the estimate is drawn.
const CURVE_POINTS: usize = 600;

/// What `caustica density` did.
#[derive(Clone, Debug)]
pub struct DensitySummary {
    /// Points read.
    pub n: usize,
    /// Bandwidth (bin width for the histogram, factor h for the variable kernel; NaN for knn).
    pub h: f64,
    /// How h was chosen.
    pub h_rule: &'static str,
}

/// Run `caustica density`: estimate and write the plot.
pub fn run(args: &DensityArgs) -> Result<DensitySummary> {
    caustica::film::output::check_output_path(&args.output)?;
    let sample = Sample::new(&read_data(&args.data)?);
    let (h, h_rule) = match args.h.as_deref() {
        None | Some("silverman") => (silverman(&sample, args.kernel), "Silverman's rule"),
        Some("cv") => (least_squares_cv(&sample, args.kernel), "least-squares cross-validation"),
        Some(v) => match v.parse::<f64>() {
            Ok(h) if h > 0.0 && h.is_finite() => (h, "given"),
            _ => {
                return Err(Error::Setting {
                    name: "h".into(),
                    problem: format!("'{v}' is not a positive number, 'silverman' or 'cv'"),
                });
            }
        },
    };
    if !(h > 0.0 && h.is_finite()) {
        return Err(Error::Setting {
            name: "h".into(),
            problem: format!("{h_rule} gives {h} for {} (no spread): give --h", args.data.display()),
        });
    }
    if !args.origin.is_finite() {
        return Err(Error::Setting {
            name: "origin".into(),
            problem: format!("{} is not finite", args.origin),
        });
    }
    let values = sample.values();
    let (lo, hi) = (values[0], values[values.len() - 1]);
    let pad = 0.1 * (hi - lo).max(h);
    let (x0, x1) = (lo - pad, hi + pad);
    let xs: Vec<f64> =
        (0..CURVE_POINTS).map(|i| x0 + (x1 - x0) * i as f64 / (CURVE_POINTS - 1) as f64).collect();
    let histogram = Histogram { origin: args.origin, width: h };
    let variable = (args.method == DensityMethod::Variable)
        .then(|| VariableKernel::new(&sample, args.kernel, h, args.k));
    let f = |x: f64| match args.method {
        DensityMethod::Histogram => histogram.density(&sample, x),
        DensityMethod::Kernel => KernelEstimate { kernel: args.kernel, h }.density(&sample, x),
        DensityMethod::Knn => KnnEstimate { k: args.k }.density(&sample, x),
        DensityMethod::Variable => variable.as_ref().map_or(0.0, |v| v.density(&sample, x)),
    };
    let ys: Vec<f64> = xs.iter().map(|&x| f(x)).collect();
    let title = match args.method {
        DensityMethod::Histogram => format!("histogram, width {h:.3}, origin {}", args.origin),
        DensityMethod::Kernel => format!("{:?} kernel, h = {h:.3} ({h_rule})", args.kernel),
        DensityMethod::Knn => format!("{}-nearest-neighbour estimate", args.k),
        DensityMethod::Variable => format!("variable {:?} kernel, h = {h:.3}, k = {}", args.kernel, args.k),
    };
    let bars = if args.method == DensityMethod::Histogram { histogram.counts(&sample) } else { Vec::new() };
    draw(&args.output, &title, &xs, &ys, values, &bars, &histogram)?;
    let h = if args.method == DensityMethod::Knn { f64::NAN } else { h };
    Ok(DensitySummary { n: values.len(), h, h_rule })
}

fn draw(
    path: &Path,
    title: &str,
    xs: &[f64],
    ys: &[f64],
    data: &[f64],
    bars: &[(i64, usize)],
    histogram: &Histogram,
) -> Result<()> {
    let plot_error =
        |e: String| Error::Output { path: path.into(), message: format!("plotting failed: {e}") };
    // Registering twice (a second plot in one process) is harmless.
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, crate::plot_text::FONT);
    let n = data.len() as f64;
    let y_max = ys.iter().copied().filter(|y| y.is_finite()).fold(0.0f64, f64::max).max(1e-12) * 1.1;
    let mut buffer = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = crate::plot_text::GlyphText::new(BitMapBackend::with_buffer(&mut buffer, SIZE))
            .into_drawing_area();
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(64)
            .build_cartesian_2d(xs[0]..xs[xs.len() - 1], 0.0..y_max)
            .map_err(|e| plot_error(e.to_string()))?;
        chart.configure_mesh().y_desc("density").draw().map_err(|e| plot_error(e.to_string()))?;
        let grey = RGBColor(200, 200, 210);
        chart
            .draw_series(bars.iter().map(|&(bin, count)| {
                let x = histogram.origin + bin as f64 * histogram.width;
                let y = count as f64 / (n * histogram.width);
                Rectangle::new([(x, 0.0), (x + histogram.width, y)], grey.filled())
            }))
            .map_err(|e| plot_error(e.to_string()))?;
        chart
            .draw_series(LineSeries::new(
                xs.iter().zip(ys).map(|(&x, &y)| (x, if y.is_finite() { y.min(y_max) } else { y_max })),
                BLUE.stroke_width(2),
            ))
            .map_err(|e| plot_error(e.to_string()))?;
        // The rug: one tick per data point along the axis.
        chart
            .draw_series(data.iter().map(|&x| PathElement::new(vec![(x, 0.0), (x, 0.04 * y_max)], BLACK)))
            .map_err(|e| plot_error(e.to_string()))?;
        root.present().map_err(|e| plot_error(e.to_string()))?;
    }
    let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, buffer).expect("buffer matches the plot size");
    image.save(path).map_err(|e| Error::Output { path: path.into(), message: e.to_string() })
}
