//! The error-against-time chart of `cargo bench --bench convergence`: one curve per method and
//! region (log-log), the caustic drawn thick; the contour left out (it follows the caustic).

use super::{Curve, REGIONS};
use plotters::prelude::*;

/// Draws `curves` of scene `name` onto `area`; `sets` are the regions' pixels (empty regions are
/// skipped).
pub fn chart<DB: DrawingBackend>(
    area: DrawingArea<DB, plotters::coord::Shift>,
    name: &str,
    curves: &[Curve],
    sets: &[&Vec<usize>; 4],
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE)?;
    let finite = |v: f64| v.is_finite() && v > 0.0;
    let all: Vec<(f64, f64)> = curves
        .iter()
        .flat_map(|c| {
            c.points
                .iter()
                .flat_map(|p| p.1.iter().map(move |e| (p.0, *e)))
        })
        .filter(|p| finite(p.0) && finite(p.1))
        .collect();
    let (tmin, tmax) = all
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (emin, emax) = all
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let mut chart = ChartBuilder::on(&area)
        .caption(format!("{name}: error against time"), ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(
            (tmin * 0.8..tmax * 1.25).log_scale(),
            (emin * 0.8..emax * 1.25).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("seconds, log scale")
        .y_desc("relRMSE, log scale")
        .x_label_formatter(&|v| format!("{v:.2}"))
        .y_label_formatter(&|v| format!("{v:.3}"))
        .label_style(("sans-serif", 14))
        .draw()?;
    for (ci, curve) in curves.iter().enumerate() {
        for (ri, region) in REGIONS.iter().enumerate() {
            if sets[ri].is_empty() || *region == "contour" {
                continue;
            }
            let color = Palette99::pick(ci).to_rgba();
            let series: Vec<(f64, f64)> = curve
                .points
                .iter()
                .map(|p| (p.0, p.1[ri]))
                .filter(|p| finite(p.0) && finite(p.1))
                .collect();
            let width = if ri == 1 { 3 } else { 1 };
            chart
                .draw_series(LineSeries::new(series.clone(), color.stroke_width(width)))?
                .label(format!("{} - {region}", curve.method))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(width))
                });
            chart.draw_series(series.iter().map(|p| Circle::new(*p, 3, color.filled())))?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    area.present()?;
    Ok(())
}
