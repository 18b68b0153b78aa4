//! The plot writer's output: well-formed, one line per series, round ticks.

use sugarshack_experiments::svg::{nice_ticks, Plot, Series, Stroke, COLORS};

#[test]
fn ticks_are_round_steps_covering_the_range() {
    for (lo, hi, target) in [
        (0.0, 100.0, 10),
        (0.5, 1.2, 8),
        (-3.7, 12.2, 6),
        (0.0, 0.003, 5),
    ] {
        let ticks = nice_ticks(lo, hi, target);
        assert!(
            ticks[0] <= lo && *ticks.last().unwrap() >= hi,
            "{ticks:?} covers [{lo}, {hi}]"
        );
        let step = ticks[1] - ticks[0];
        let mantissa = step / 10f64.powf(step.log10().floor());
        assert!(
            [1.0, 2.0, 5.0].iter().any(|m| (mantissa - m).abs() < 1e-6),
            "step {step} is 1, 2 or 5 times a power of ten"
        );
        assert!(ticks
            .windows(2)
            .all(|w| ((w[1] - w[0]) - step).abs() < 1e-9 * step.max(1.0)));
        assert!(
            ticks.len() <= 2 * target + 2,
            "{} ticks for a target of {target}",
            ticks.len()
        );
    }
}

#[test]
fn a_plot_has_one_polyline_per_series_a_legend_and_escaped_text() {
    let plot = Plot {
        title: "flow <gal/min> & set point".into(),
        x_label: "time (s)".into(),
        y_label: "flow".into(),
        series: vec![
            Series::new(
                "set point",
                vec![(0.0, 1.0), (10.0, 1.0)],
                COLORS[4],
                Stroke::Dashed,
            ),
            Series::new(
                "RCC",
                (0..5000)
                    .map(|k| (k as f64 * 0.002, (k as f64).sin()))
                    .collect(),
                COLORS[1],
                Stroke::Solid,
            ),
        ],
        x_range: None,
        y_range: None,
    };
    let svg = plot.to_svg();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert_eq!(svg.matches("<polyline").count(), 2);
    assert!(svg.contains("stroke-dasharray"), "the set point is dashed");
    assert!(svg.contains("flow &lt;gal/min&gt; &amp; set point"));
    assert!(!svg.contains("<gal/min>"));
    assert!(svg.contains(">RCC</text>") && svg.contains(">set point</text>"));
    let longest = svg
        .lines()
        .filter(|l| l.contains("<polyline"))
        .map(|l| l.matches(',').count())
        .max()
        .unwrap();
    assert!(
        longest <= 2001,
        "5000 points are thinned for the file, got {longest}"
    );
}
