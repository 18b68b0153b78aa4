//! Runs the paper's fault-tolerance and delay-compensation experiments, prints
//! each result beside the paper's claim, and writes the figures as SVG.
//!
//! Usage: control-report [--out <dir>]   (default: report)

use std::fs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use sugarshack_experiments::delay_compensation::{self as dc, CaseResults, Compensation, Table3};
use sugarshack_experiments::fault_tolerance::{self as ft, Figure11};
use sugarshack_experiments::metrics::Trace;
use sugarshack_experiments::sim::DelayDist;
use sugarshack_experiments::svg::{Plot, Series, Stroke, COLORS};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = match args.as_slice() {
        [] => PathBuf::from("report"),
        [flag, dir] if flag == "--out" => PathBuf::from(dir),
        _ => {
            eprintln!("usage: control-report [--out <dir>]");
            return ExitCode::from(2);
        }
    };
    match run(&out) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("control-report: {message}");
            ExitCode::FAILURE
        }
    }
}

fn run(out: &Path) -> Result<(), String> {
    fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let figure = ft::figure11().map_err(|e| e.to_string())?;
    print_table2(&figure)?;
    let table = Table3::run(dc::SEEDS).map_err(|e| e.to_string())?;
    print_table3(&table)?;
    write_figures(out, &figure, &table)?;
    println!("\nfigures written to {}", out.display());
    Ok(())
}

fn print_table2(figure: &Figure11) -> Result<(), String> {
    let zn = ft::ziegler_nichols();
    let pi = ft::tuning();
    let [d1, d2] = ft::ENGAGEMENT_THRESHOLDS_MS;
    println!("TABLE 2 / FIG. 11  fault tolerance under RCC");
    println!(
        "  flow process K = {}, tau = {} s, no dead time of its own; Ts = {} ms; round trip {} ms ({} ms each way)",
        ft::FLOW_PROCESS.gain,
        ft::FLOW_PROCESS.tau_s,
        ft::TS_MS,
        ft::ROUND_TRIP_MS,
        ft::ONE_WAY_DELAY_MS
    );
    println!(
        "  PI: Ziegler-Nichols on the loop seen (L = RTT + Ts/2 = {:.2} s): Kp = {:.2}, Ti = {:.2} s",
        ft::apparent_dead_time(),
        zn.kp,
        zn.ti_s
    );
    println!(
        "      used: Ti = {:.2} s, Kp = {:.4} for a {} rad/s crossover (ZN's gain / {:.0})",
        pi.ti_s,
        pi.kp,
        ft::TARGET_CROSSOVER_RAD_S,
        zn.kp / pi.kp
    );
    println!(
        "  D1 = {d1} ms, D2 = {d2} ms; backup started at {:.2} s; the primary's link is down {}-{} s",
        ft::BACKUP_START_MS as f64 / 1000.0,
        ft::FAIL_AT_S,
        ft::RECOVER_AT_S
    );
    let base = figure.no_failure.metrics();
    let band = sugarshack_experiments::metrics::max_difference(
        &figure.rcc.output,
        &figure.no_failure.output,
        0.0,
        ft::DURATION_S,
    );
    let events = ft::handover_events(&figure.rcc);
    let bumps = ft::event_bumps(&figure.rcc_no_smooth_handover, &figure.no_failure);
    let stall = ft::stall(&figure.no_redundancy);
    let theorem = ft::theorem3(figure).map_err(|e| e.to_string())?;
    let (worst_at, worst) = theorem.worst();
    let rows: Vec<(String, String, &str)> = vec![
        (
            "no failure: overshoot, settling (5 % band)".into(),
            format!(
                "{:.2} %, {:.2} s after the step",
                base.overshoot_pct,
                base.settling_time_s.unwrap_or(f64::NAN)
            ),
            "reaches the steady state",
        ),
        (
            "no failure: flow at the failure instant".into(),
            format!(
                "{:.3} gal/min (set point {})",
                figure
                    .no_failure
                    .output
                    .at(ft::FAIL_AT_S)
                    .unwrap_or(f64::NAN),
                ft::SET_POINT_STEP.setpoint
            ),
            "22 s is in the transient",
        ),
        (
            "RCC: max |flow - no-failure flow|".into(),
            format!("{band:.5} gal/min"),
            "as if there are no failures",
        ),
        (
            "RCC: handover events".into(),
            events
                .iter()
                .map(|t| format!("{t:.2} s"))
                .collect::<Vec<_>>()
                .join(", "),
            "one in the transient, one in steady state",
        ),
        (
            "RCC without smooth handover: bumps".into(),
            bumps
                .iter()
                .map(|(t, b)| format!("{b:.3} gal/min at {t:.2} s"))
                .collect::<Vec<_>>()
                .join(", "),
            "two bumps",
        ),
        (
            format!(
                "no redundancy: flow {:.0}-{:.0} s",
                stall.from_s, stall.to_s
            ),
            format!(
                "{:.4} gal/min, swing {:.1e}, {:.3} below the set point",
                stall.level,
                stall.swing,
                stall.setpoint - stall.level
            ),
            "left at an intermediate value",
        ),
        (
            "Theorem 3: bound on added settling time".into(),
            format!(
                "(ceil(({} + {d2}) / {}) - 2) samples = {:.2} s",
                ft::ROUND_TRIP_MS,
                ft::TS_MS,
                theorem.bound_s
            ),
            "Delta t_s = ceil((RTT_j + D_j)/Ts) - 2",
        ),
        (
            "  detection-gap bound of this model".into(),
            format!(
                "ceil(({} + {d2}) / {}) samples = {:.2} s",
                ft::ROUND_TRIP_MS,
                ft::TS_MS,
                theorem.gap_bound_s
            ),
            "-",
        ),
        (
            "  added settling time, failure at 22 s".into(),
            format!(
                "{:.2} s ({})",
                theorem.added_at_paper_failure_s,
                verdict(theorem.added_at_paper_failure_s, &theorem)
            ),
            "within the bound",
        ),
        (
            format!(
                "  worst, failures {:.2}-{:.2} s every {} s",
                theorem.sweep.first().map_or(f64::NAN, |p| p.0),
                theorem.sweep.last().map_or(f64::NAN, |p| p.0),
                ft::SWEEP_STEP_S
            ),
            format!(
                "{worst:.2} s at {worst_at:.2} s ({})",
                verdict(worst, &theorem)
            ),
            "within the bound",
        ),
    ];
    println!("  {:<50} | {:<62} | paper", "measure", "this simulation");
    println!("  {}", "-".repeat(150));
    for (what, value, claim) in rows {
        println!("  {what:<50} | {value:<62} | {claim}");
    }
    Ok(())
}

fn verdict(added_s: f64, theorem: &ft::Theorem3) -> &'static str {
    match (added_s <= theorem.bound_s, added_s <= theorem.gap_bound_s) {
        (true, _) => "within the paper's bound",
        (false, true) => "above the paper's bound, within the gap bound",
        (false, false) => "above both bounds",
    }
}

fn delay_label(scale: Option<f64>) -> Result<String, String> {
    match scale {
        None => Ok("no delay".into()),
        Some(scale) => {
            let d = DelayDist::ds2_scaled(scale).map_err(|e| e.to_string())?;
            Ok(format!(
                "({}, {}, {})",
                d.mean_ms() / 1000.0,
                d.sd_ms() / 1000.0,
                d.max_ms() / 1000.0
            ))
        }
    }
}

fn seconds(value: Option<f64>) -> String {
    value.map_or("never".into(), |v| format!("{v:.1}"))
}

fn paper_claim(scale_index: Option<usize>, compensation: Compensation) -> &'static str {
    match (scale_index, compensation) {
        (None, _) => "baseline",
        (Some(0 | 1), Compensation::None) => "overshoots (Figs. 12a, 12b)",
        (Some(2), Compensation::None) => "like (4, 2.8, 20); not shown",
        (Some(_), Compensation::None) => "unstable (Fig. 12c)",
        (Some(_), Compensation::Fixed) => "no apparent overshoot (worst run)",
        (Some(_), Compensation::Adaptive) => "not in Table 3 (proposed in §4)",
    }
}

fn print_table3(table: &Table3) -> Result<(), String> {
    let zn = dc::ziegler_nichols();
    let pi = dc::tuning();
    println!("\nTABLE 3 / FIG. 12  delay compensation");
    println!(
        "  flow process K = {}, tau = {} s; Ts = {} ms; unit step at 0 s after {} s at rest; {} s run; {} seeds per delay",
        dc::FLOW_PROCESS.gain,
        dc::FLOW_PROCESS.tau_s,
        dc::TS_MS,
        dc::WARM_UP_S,
        dc::DURATION_S,
        dc::SEEDS
    );
    println!(
        "  PI: Ziegler-Nichols for the loop without delay (L = Ts/2 of hold = {:.2} s): Kp = {:.2}, Ti = {:.2} s",
        dc::apparent_dead_time(),
        zn.kp,
        zn.ti_s
    );
    println!(
        "      used: Ti = {:.2} s, Kp = {:.4} for a crossover of pi/(3 x {:.1} s) = {:.3} rad/s (ZN's gain / {:.0})",
        pi.ti_s,
        pi.kp,
        dc::largest_under_estimate_s(),
        dc::target_crossover_rad_s(),
        zn.kp / pi.kp
    );
    println!(
        "  round trip: one DS2-shaped draw per action on its way out, TCP order, last of a batch written; adaptive: alpha = {}, h = {}",
        dc::ADAPTIVE_ALPHA,
        dc::ADAPTIVE_H
    );
    println!(
        "  {:<19} | {:<17} | {:<13} | {:<22} | {:<9} | {:<14} | {:<13} | {:<20} | paper",
        "delay (mu,sd,max) s",
        "method",
        "D_c (paper)",
        "Mp % best/median/worst",
        "max|e_ss|",
        "t_s s best/wst",
        "t_ps best/wst",
        "unsettled (swinging)"
    );
    println!("  {}", "-".repeat(170));
    let mut rows: Vec<(Option<usize>, &CaseResults)> = vec![(None, &table.zero_delay)];
    for (i, row) in table.rows.iter().enumerate() {
        rows.extend(row.iter().map(|case| (Some(i), case)));
    }
    for (index, case) in rows {
        let (best, worst) = (&case.best().2, &case.worst().2);
        let dead_time = match (case.compensation, index) {
            (Compensation::None, _) | (_, None) => "-".to_string(),
            (Compensation::Fixed, Some(i)) => format!(
                "{} ({})",
                dc::fixed_dead_time_samples(dc::DS2_SCALES[i]).map_err(|e| e.to_string())?,
                dc::PAPER_DEAD_TIME_SAMPLES[i]
            ),
            (Compensation::Adaptive, Some(_)) => {
                let (lo, hi) = case.dead_time_range();
                format!("{lo}..{hi}")
            }
        };
        let pure = |m: &sugarshack_experiments::metrics::StepMetrics, run: &dc::DelayRun| match case
            .compensation
        {
            Compensation::None => "-".to_string(),
            _ => seconds(m.pure_settling_time_s(run.dead_time_at_step_s())),
        };
        let max_ess = case
            .runs
            .iter()
            .filter(|(_, _, m)| m.settling_time_s.is_some())
            .map(|(_, _, m)| m.steady_state_error.abs())
            .fold(f64::NAN, f64::max);
        println!(
            "  {:<19} | {:<17} | {:<13} | {:<22} | {:<9} | {:<14} | {:<13} | {:<20} | {}",
            delay_label(case.scale)?,
            case.compensation.label(),
            dead_time,
            format!(
                "{:.1} / {:.1} / {:.1}",
                best.overshoot_pct,
                case.median_overshoot_pct(),
                worst.overshoot_pct
            ),
            if max_ess.is_nan() {
                "-".to_string()
            } else {
                format!("{max_ess:.4}")
            },
            format!(
                "{} / {}",
                seconds(best.settling_time_s),
                seconds(worst.settling_time_s)
            ),
            format!(
                "{} / {}",
                pure(best, &case.best().1),
                pure(worst, &case.worst().1)
            ),
            format!(
                "{}/{} ({})",
                case.unsettled_runs(),
                case.runs.len(),
                case.unstable_runs()
            ),
            paper_claim(index, case.compensation)
        );
    }
    println!(
        "  best/worst: settled runs before unsettled ones, then by overshoot. Unsettled: outside the 5 % band in the last {} s;",
        dc::TAIL_S
    );
    println!(
        "  swinging: of those, still swinging by more than twice the band's width over the last quarter of the run."
    );
    Ok(())
}

fn write(out: &Path, name: &str, plot: &Plot) -> Result<(), String> {
    let path = out.join(name);
    fs::write(&path, plot.to_svg()).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

fn series(label: &str, trace: &Trace, color: &'static str, stroke: Stroke) -> Series {
    Series::new(label, trace.points(), color, stroke)
}

fn set_point_series(points: Vec<(f64, f64)>) -> Series {
    Series::new("set point", points, COLORS[4], Stroke::Dashed)
}

fn write_figures(out: &Path, figure: &Figure11, table: &Table3) -> Result<(), String> {
    let set_point: Vec<(f64, f64)> = figure
        .no_failure
        .output
        .times_s
        .iter()
        .map(|&t| (t, ft::set_point(t)))
        .collect();
    let flow_axes = |title: &str, series: Vec<Series>, y_range: (f64, f64)| Plot {
        title: title.into(),
        x_label: "time (s)".into(),
        y_label: "flow (gal/min)".into(),
        series,
        x_range: Some((0.0, ft::DURATION_S)),
        y_range: Some(y_range),
    };
    write(
        out,
        "fig11a.svg",
        &flow_axes(
            "Fig. 11a: RCC under a primary failure (22-78 s)",
            vec![
                set_point_series(set_point.clone()),
                series(
                    "no failure",
                    &figure.no_failure.output,
                    COLORS[0],
                    Stroke::Dotted,
                ),
                series("RCC", &figure.rcc.output, COLORS[1], Stroke::Solid),
                series(
                    "no redundancy",
                    &figure.no_redundancy.output,
                    COLORS[2],
                    Stroke::Solid,
                ),
            ],
            (0.6, 1.1),
        ),
    )?;
    write(
        out,
        "fig11b.svg",
        &flow_axes(
            "Fig. 11b: RCC with and without smooth handover",
            vec![
                set_point_series(set_point),
                series("RCC", &figure.rcc.output, COLORS[1], Stroke::Solid),
                series(
                    "RCC (no S.H.)",
                    &figure.rcc_no_smooth_handover.output,
                    COLORS[0],
                    Stroke::Solid,
                ),
            ],
            (0.0, 1.2),
        ),
    )?;
    // The paper shows the 1, 2 and 4 s delays as 12a-c; the 3 s one it left out is 12d here.
    for (name, index) in [
        ("fig12a.svg", 0),
        ("fig12b.svg", 1),
        ("fig12c.svg", 3),
        ("fig12d.svg", 2),
    ] {
        let [uncompensated, fixed, adaptive] = &table.rows[index];
        let label = delay_label(Some(dc::DS2_SCALES[index]))?;
        let zero = &table.zero_delay.runs[0].1.output;
        let step: Vec<(f64, f64)> = zero
            .times_s
            .iter()
            .map(|&t| (t, dc::UNIT_STEP.setpoint))
            .collect();
        let plot = Plot {
            title: format!("Fig. 12: round trip (mu, sd, max) = {label} s"),
            x_label: "time (s)".into(),
            y_label: "flow (gal/min)".into(),
            series: vec![
                set_point_series(step),
                series("no delay", zero, COLORS[4], Stroke::Dotted),
                series(
                    "uncompensated (best)",
                    &uncompensated.best().1.output,
                    COLORS[1],
                    Stroke::Solid,
                ),
                series(
                    "Smith, fixed D_c (worst)",
                    &fixed.worst().1.output,
                    COLORS[0],
                    Stroke::Solid,
                ),
                series(
                    "Smith, adaptive (worst)",
                    &adaptive.worst().1.output,
                    COLORS[2],
                    Stroke::Dashed,
                ),
            ],
            x_range: Some((0.0, dc::DURATION_S)),
            y_range: Some((0.0, 2.2)),
        };
        write(out, name, &plot)?;
    }
    Ok(())
}
