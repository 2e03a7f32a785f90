//! Every plot the tool writes, rendered to PNG with `resvg` and checked to be a picture a
//! person can read: the main job's cycle plot, the pull plot, the paper plot, the accuracy
//! report's plots and the robustness plot.
//!
//! Each figure is built by the same library call its command uses, from a short run, then
//! rasterised with the system's fonts. A figure passes when
//! - the image is the size its geometry says, and not blank (enough ink overall);
//! - it has colour: several distinct hues, i.e. the series and bands were drawn;
//! - every panel's plot area holds coloured ink (its data, not just its grid);
//! - its text was rendered: the title strip and the y-label column hold dark ink.
//!
//! The PNGs are left in `target/tmp/plots/` (`CARGO_TARGET_TMPDIR`) to be looked at.
//! Text needs a font: on a machine without any (a bare container), install one, e.g.
//! `apt-get install fonts-dejavu-core`; the test says so instead of passing blind.
#![allow(
    clippy::expect_used,
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    clippy::float_arithmetic,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_precision_loss,
    clippy::print_stdout,
    clippy::panic,
    reason = "a test: a panic is how it reports, and it prints what it measured"
)]

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use clap::Parser as _;
use resvg::tiny_skia::{Pixmap, Transform};
use resvg::usvg::{Options, Tree, fontdb};
use taut::cli::{Cli, Command, ReportKind};
use taut::job::CycleRun;
use taut::plot::{Content, Figure, Geometry, Series};
use taut::report::accuracy;

/// The system's fonts, loaded once.
fn fonts() -> Arc<fontdb::Database> {
    static FONTS: OnceLock<Arc<fontdb::Database>> = OnceLock::new();
    FONTS
        .get_or_init(|| {
            let mut db = fontdb::Database::new();
            db.load_system_fonts();
            assert!(
                !db.is_empty(),
                "no fonts on this machine: the plots' text cannot be rendered (install one, \
                 e.g. `apt-get install fonts-dejavu-core`)"
            );
            Arc::new(db)
        })
        .clone()
}

/// A rendered figure.
struct Picture {
    pixmap: Pixmap,
    geometry: Geometry,
}

impl Picture {
    /// RGB of pixel (x, y) (the background is opaque white, so alpha is 255).
    fn rgb(&self, x: u32, y: u32) -> [u8; 3] {
        let p = self.pixmap.pixel(x, y).unwrap();
        [p.red(), p.green(), p.blue()]
    }

    /// Pixels in the rectangle `x0..x1 × y0..y1` that satisfy `f`.
    fn count(&self, (x0, y0, x1, y1): (f64, f64, f64, f64), f: impl Fn([u8; 3]) -> bool) -> usize {
        let clamp = |v: f64, max: u32| (v.max(0.0) as u32).min(max);
        let (w, h) = (self.pixmap.width(), self.pixmap.height());
        let mut n = 0;
        for y in clamp(y0, h)..clamp(y1, h) {
            for x in clamp(x0, w)..clamp(x1, w) {
                if f(self.rgb(x, y)) {
                    n += 1;
                }
            }
        }
        n
    }
}

/// Ink: anything not (near) white.
fn ink(rgb: [u8; 3]) -> bool {
    rgb.iter().any(|&c| c < 235)
}

/// Dark ink: text and frames.
fn dark(rgb: [u8; 3]) -> bool {
    rgb.iter().all(|&c| c < 120)
}

/// Coloured ink: a clear hue (series, bands), not the greys of grid, frame and text.
fn coloured(rgb: [u8; 3]) -> bool {
    let max = *rgb.iter().max().unwrap();
    let min = *rgb.iter().min().unwrap();
    max - min > 40
}

/// Renders `figure` to PNG as `name` under `target/tmp/plots/` and checks it (see the
/// module docs).
fn check(name: &str, figure: &Figure) -> Picture {
    let (svg, geometry) = figure.render();
    let options = Options { fontdb: fonts(), ..Options::default() };
    let tree = Tree::from_str(&svg, &options).expect("the SVG parses");
    let size = tree.size().to_int_size();
    assert_eq!(
        (f64::from(size.width()), f64::from(size.height())),
        (geometry.width, geometry.height)
    );
    let mut pixmap = Pixmap::new(size.width(), size.height()).unwrap();
    resvg::render(&tree, Transform::default(), &mut pixmap.as_mut());
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("plots");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{name}.png"));
    pixmap.save_png(&path).unwrap();
    let picture = Picture { pixmap, geometry };

    let (w, h) = (f64::from(size.width()), f64::from(size.height()));
    let all = (0.0, 0.0, w, h);
    let inked = picture.count(all, ink) as f64 / (w * h);
    let hues: HashSet<[u8; 3]> = (0..size.height())
        .flat_map(|y| (0..size.width()).map(move |x| (x, y)))
        .map(|(x, y)| picture.rgb(x, y))
        .filter(|&rgb| coloured(rgb))
        .map(|rgb| rgb.map(|c| c / 32))
        .collect();
    let title = picture.count((0.0, 0.0, w, 48.0), dark);
    let y_labels = picture.count((0.0, 48.0, 32.0, h), dark);
    println!(
        "{}: {}×{} px, {:.1} % inked, {} hues, title {title} dark px, y labels {y_labels} dark px",
        path.display(),
        size.width(),
        size.height(),
        inked * 100.0,
        hues.len()
    );
    assert!(inked > 0.03, "{name}: almost blank ({:.2} % inked)", inked * 100.0);
    assert!(hues.len() >= 5, "{name}: only {} hues", hues.len());
    assert!(title > 400, "{name}: the title was not rendered ({title} dark px)");
    assert!(y_labels > 100 * figure.panels.len(), "{name}: the y labels were not rendered");
    // A log axis cannot show zero: its label says where a zero (or a value below the
    // axis's floor) is drawn.
    for panel in &figure.panels {
        if panel.scale == taut::plot::Scale::Log {
            assert!(panel.y_label.contains("shown at"), "{name}: log axis {:?}", panel.y_label);
        }
    }
    for (index, (panel, area)) in
        figure.panels.iter().zip(&picture.geometry.panels).map(|(p, g)| (p, g.area)).enumerate()
    {
        let rect = (area.x + 1.0, area.y + 1.0, area.x + area.w - 1.0, area.y + area.h - 1.0);
        let drawn = picture.count(rect, coloured);
        let needed = match panel.content {
            Content::Lines(_) => 100,
            Content::Timeline(_) => 500,
        };
        assert!(
            drawn >= needed,
            "{name}: panel {index} ({}) shows no data ({drawn} coloured px)",
            panel.y_label
        );
    }
    picture
}

fn parse(args: &[&str]) -> Cli {
    Cli::try_parse_from(std::iter::once("taut").chain(args.iter().copied())).unwrap()
}

#[test]
fn the_main_jobs_plot() {
    let cli = parse(&["--hold", "5"]);
    let options = taut::job::options_from_args(&cli.job);
    let run: CycleRun = taut::job::run(&options, None, &mut |_| {}).expect("the job runs");
    let figure = taut::job::figure::figure(&run);
    let picture = check("cycle", &figure);
    assert!(picture.geometry.panels.len() >= 6, "tension … state timeline and the zoomed hold");
}

/// The main job's figure for `args`, checked and rendered as `name`.
fn main_job(name: &str, args: &[&str]) -> (CycleRun, Figure, Picture) {
    let cli = parse(args);
    let options = taut::job::options_from_args(&cli.job);
    let run: CycleRun = taut::job::run(&options, None, &mut |_| {}).expect("the job runs");
    let figure = taut::job::figure::figure(&run);
    let picture = check(name, &figure);
    (run, figure, picture)
}

/// The series of `panel` whose label starts with `label`.
fn series<'a>(figure: &'a Figure, panel: usize, label: &str) -> Option<&'a Series> {
    match &figure.panels.get(panel)?.content {
        Content::Lines(all) => all.iter().find(|s| s.label.starts_with(label)),
        Content::Timeline(_) => None,
    }
}

/// An uncalibrated machine holds off its target: the hold zoom widens to show the true
/// tension (it used to stay at ±0.2 kgf, an empty panel), and whatever is beyond it is
/// marked off scale.
#[test]
fn an_uncalibrated_runs_hold_zoom_shows_the_hold() {
    let (_, figure, picture) = main_job("cycle-uncalibrated", &["--uncalibrated", "--hold", "5"]);
    let zoom = figure.panels.last().unwrap();
    let (lo, hi) = zoom.y_range.expect("a fixed zoom");
    let held = series(&figure, figure.panels.len() - 1, "true tension").unwrap();
    // The zoom runs from half a second before the hold to half a second after it; the
    // settled hold starts half a second in.
    let (from, to) = zoom.x_range.unwrap();
    let settled: Vec<f64> =
        held.points.iter().filter(|p| p.0 >= from + 1.0 && p.0 <= to - 0.5).map(|p| p.1).collect();
    let off = settled.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    println!("hold zoom ±{hi}, the settled hold's largest error {off:.3}");
    assert!(off > 0.2, "the uncalibrated machine holds off target ({off:.3})");
    assert!(settled.iter().all(|v| *v > lo && *v < hi), "the settled hold is on the zoom");
    assert!(zoom.y_label.contains(&format!("±{hi}")), "{}", zoom.y_label);
    // The true tension's line is drawn inside the zoom's plot area (coloured ink).
    let area = picture.geometry.panels.last().unwrap().area;
    let drawn = picture.count(
        (area.x + 1.0, area.y + 1.0, area.x + area.w - 1.0, area.y + area.h - 1.0),
        coloured,
    );
    assert!(drawn > 300, "the hold panel shows the hold ({drawn} coloured px)");
}

/// A job set in pounds is plotted in pounds; a pre-stretch's peak target is drawn.
#[test]
fn a_job_in_pounds_with_a_pre_stretch_is_plotted_in_pounds_with_its_peak_target() {
    let (run, figure, _) = main_job(
        "cycle-lb-prestretch",
        &["--tension", "55lb", "--pre-stretch", "10", "--hold", "5"],
    );
    assert!(run.completed);
    assert_eq!(figure.panels[0].y_label, "tension (lb)");
    let target = series(&figure, 0, "target").unwrap();
    assert!(target.points.iter().all(|p| (p.1 - 55.0).abs() < 0.01), "{:?}", target.points);
    let peak = series(&figure, 0, "peak target (pre-stretch)").expect("the peak target is drawn");
    assert!(peak.points.iter().all(|p| (p.1 - 60.5).abs() < 0.1), "{:?}", peak.points);
    let truth = series(&figure, 0, "true tension").unwrap();
    let top = truth.points.iter().fold(0.0_f64, |m, p| m.max(p.1));
    assert!((58.0..63.0).contains(&top), "the true tension in lb reaches the peak: {top}");
    let zoom = figure.panels.last().unwrap();
    assert!(zoom.y_label.starts_with("hold: tension − target (lb)"), "{}", zoom.y_label);
    assert!(zoom.y_range.is_some_and(|(_, hi)| hi >= 0.5), "±0.5 lb at least");
}

/// A faulted run's plot says so: the fault's code and moment in the title and as a line
/// across the tension panel.
#[test]
fn a_faulted_runs_plot_marks_the_fault() {
    let (run, figure, _) = main_job("cycle-fault", &["--string", "none", "--hold", "5"]);
    assert!(!run.completed);
    assert!(figure.title.contains("fault E-16 at"), "{}", figure.title);
    let mark = series(&figure, 0, "fault E-16 at").expect("the fault is marked");
    assert_eq!(mark.points.len(), 2);
    assert!((mark.points[0].0 - mark.points[1].0).abs() < 1e-9, "a vertical line");
}

#[test]
fn the_pull_plot() {
    let cli = parse(&["pull", "--tension", "25", "--hold", "5"]);
    let Some(Command::Pull(args)) = &cli.command else { panic!("pull") };
    let pull = taut::pull::run(args).expect("the pull runs");
    let figure = pull.figure(args);
    check("pull", &figure);
    // In the hold zoom the measured tension does not bury the true one: within 0.05 kgf rms.
    let zoom = figure.panels.len() - 1;
    let measured = series(&figure, zoom, "measured").expect("the measured tension");
    let truth = series(&figure, zoom, "true").expect("the true tension");
    let squares: f64 =
        measured.points.iter().zip(&truth.points).map(|(m, t)| (m.1 - t.1).powi(2)).sum();
    let rms = (squares / truth.points.len() as f64).sqrt();
    assert!(rms < 0.05, "the measured tension strays {rms:.3} kgf rms from the true one");
}

#[test]
fn the_paper_plot() {
    let (rsmc, pd, _) = taut::paper::run();
    check("paper", &taut::paper::figure(&rsmc, &pd));
}

#[test]
fn the_accuracy_plots() {
    let cli = parse(&["report", "accuracy", "--scenarios", "6", "--controllers", "taut,pd"]);
    let Some(Command::Report { which: ReportKind::Accuracy(args) }) = &cli.command else {
        panic!("report accuracy")
    };
    let lineup = accuracy::lineup(&args.controllers);
    let results = accuracy::run_all(args.seed, args.scenarios, args.machines(), &lineup, 2);
    let figures = accuracy::figures(args.seed, args.machines(), &results, &lineup);
    assert_eq!(figures.len(), 2, "the quantiles and one scenario");
    for (file, figure) in &figures {
        let stem = file.trim_end_matches(".svg");
        let name =
            if stem.starts_with("accuracy") { stem.to_owned() } else { format!("accuracy_{stem}") };
        check(&name, figure);
    }
    let quantiles = &figures[0].1;
    // The log axes say where they put a zero.
    assert!(quantiles.panels[0].y_label.contains("< 0.001 shown at 0.001"));
    // One percentile axis for every controller: of all the scenarios, each line ending
    // where its survivors do (pd made to fail every other scenario here).
    let mut halved = results.clone();
    for r in halved.iter_mut().step_by(2) {
        r.metrics[1] = taut::report::Metrics::failed(taut::report::Failure::NeverSettled);
    }
    let results = halved;
    let figures = accuracy::figures(args.seed, args.machines(), &results, &lineup);
    let quantiles = &figures[0].1;
    for panel in &quantiles.panels {
        let Content::Lines(all) = &panel.content else { continue };
        for (which, series) in all.iter().filter(|s| !s.label.starts_with("goal")).enumerate() {
            let survivors = results.iter().filter(|r| r.metrics[which].failure.is_none()).count();
            let end = series.points.last().map_or(0.0, |p| p.0);
            let want = survivors as f64 / results.len() as f64 * 100.0;
            assert!((end - want).abs() < 1e-9, "{}: ends at {end}, want {want}", series.label);
        }
    }
    // The scenario plotted is taut's worst hold, not the first scenario: with the last
    // surviving scenario made the worst, it is the one drawn.
    let mut worse = results.clone();
    let last = worse.iter_mut().rev().find(|r| r.metrics[0].failure.is_none()).unwrap();
    last.metrics[0].hold_error_kgf = 9.0;
    let index = last.index;
    assert_ne!(index, 0);
    let figures = accuracy::figures(args.seed, args.machines(), &worse, &lineup);
    assert_eq!(figures[1].0, format!("scenario_{index}.svg"));
    assert!(figures[1].1.title.contains("taut's worst hold (9.000 kgf)"), "{}", figures[1].1.title);

    // A controller that failed every scenario gets no empty legend entry; the subtitle names it.
    let mut failed = results.clone();
    for r in &mut failed {
        r.metrics[1] = taut::report::Metrics::failed(taut::report::Failure::NeverSettled);
    }
    let figures = accuracy::figures(args.seed, args.machines(), &failed, &lineup);
    let quantiles = &figures[0].1;
    assert!(quantiles.subtitle.contains("every scenario failed for pd"), "{}", quantiles.subtitle);
    for panel in &quantiles.panels {
        let Content::Lines(all) = &panel.content else { continue };
        assert!(all.iter().all(|s| !s.points.is_empty() && !s.label.starts_with("pd")));
    }
}

/// `--gauge-sigma` commissions the report's machines against the gauge it names: the same
/// machines, strings and targets, a different calibration (every scenario's sensing offset
/// moves), and the summary records which gauge it was.
#[test]
fn the_accuracy_report_calibrates_against_the_gauge_it_is_given() {
    let run = |extra: &[&str]| {
        let mut line = vec!["report", "accuracy", "--scenarios", "3"];
        line.extend_from_slice(extra);
        let cli = parse(&line);
        let Some(Command::Report { which: ReportKind::Accuracy(args) }) = &cli.command else {
            panic!("report accuracy")
        };
        let lineup = accuracy::lineup(&args.controllers);
        let machines = args.machines();
        let results = accuracy::run_all(args.seed, args.scenarios, machines, &lineup, 2);
        let json = accuracy::to_json(args.seed, machines, &results, &lineup);
        (results, json)
    };
    let (family, family_json) = run(&[]);
    let (exact, exact_json) = run(&["--gauge-sigma", "0"]);
    assert_eq!(family_json["reference_gauge_sigma_kgf"], 0.02, "the family's gauge");
    assert_eq!(exact_json["reference_gauge_sigma_kgf"], 0.0);
    for (f, e) in family.iter().zip(&exact) {
        assert_eq!((f.index, f.target_kgf, f.string), (e.index, e.target_kgf, e.string));
        let (f, e) = (&f.metrics[0], &e.metrics[0]);
        assert!(f.failure.is_none() && e.failure.is_none(), "{f:?} {e:?}");
        assert_ne!(f.sense_offset_kgf, e.sense_offset_kgf, "the calibration did not change");
    }
}

#[test]
fn the_robustness_plot() {
    let cli = parse(&["report", "robustness", "--scenarios", "1", "--axes", "inertia,friction"]);
    let Some(Command::Report { which: ReportKind::Robustness(args) }) = &cli.command else {
        panic!("report robustness")
    };
    let runs = taut::report::robustness::run_all(args);
    let axes = taut::report::robustness::axes(args);
    check("robustness", &taut::report::robustness::figure(args, &axes, &runs));
}

#[test]
fn robustness_beyond_the_family_is_reported_apart() {
    let cli = parse(&[
        "report",
        "robustness",
        "--scenarios",
        "1",
        "--points",
        "2",
        "--axes",
        "backlash",
        "--beyond",
        "0.5",
    ]);
    let Some(Command::Report { which: ReportKind::Robustness(args) }) = &cli.command else {
        panic!("report robustness")
    };
    let runs = taut::report::robustness::run_all(args);
    let axes = taut::report::robustness::axes(args);
    let positions: Vec<f64> = runs.iter().map(|p| p.position).collect();
    assert_eq!(positions, [0.0, 1.0, -0.5, 1.5]);
    // −0.5 is negative backlash: listed, not run; 1.5 (0.3 mm) is run.
    let below = &runs[2];
    assert!(below.unphysical.as_deref().is_some_and(|why| why.contains("backlash")), "{below:?}");
    let above = &runs[3];
    assert!(above.unphysical.is_none() && above.metrics.failure.is_none(), "{above:?}");
    let table = taut::report::robustness::beyond_markdown(&axes, &runs, args.beyond);
    assert!(table.contains("| backlash | -0.50 | backlash -0.1000 mm | not physical"), "{table}");
    assert!(table.contains("| backlash | 1.50 | backlash 0.3000 mm | 0."), "{table}");
    // The family's own table and worst figures leave the points beyond out.
    let family = taut::report::robustness::markdown(&axes, &runs);
    assert!(family.contains("| 0 of 2 |"), "{family}");
    let json = taut::report::robustness::to_json(args, &axes, &runs);
    let entry = &json["axes"]["backlash"];
    assert_eq!(entry["runs"], 2);
    assert_eq!(entry["beyond"][0]["position"], -0.5);
    assert!(entry["beyond"][0]["unphysical"].is_string());
    assert_eq!(entry["beyond"][1]["runs"], 1);
    assert_eq!(json["beyond"], 0.5);
}

#[test]
fn robustness_runs_the_sweeps_scenarios_on_a_corner_of_the_family() {
    let cli = parse(&[
        "report",
        "robustness",
        "--scenarios",
        "2",
        "--corner",
        "inertia=1",
        "--corner",
        "gripper-mass=1.2",
    ]);
    let Some(Command::Report { which: ReportKind::Robustness(args) }) = &cli.command else {
        panic!("report robustness")
    };
    use taut::report::robustness::{corner_machine, corner_markdown, run_corner, run_point};
    use taut_sim::Axis;
    assert_eq!(args.corner, [(Axis::Inertia, 1.0), (Axis::GripperMass, 1.2)]);
    let runs: Vec<_> = (0..2).map(|i| run_corner(&args.corner, i, args.seed, None)).collect();
    for (index, run) in (0_u64..).zip(&runs) {
        // The sweep's scenario `index`: the same string kind and target.
        let sweep = run_point(Axis::Inertia, 1.0, index, args.seed, None);
        assert_eq!((run.string, run.target_kgf), (sweep.string, sweep.target_kgf));
        assert!(run.metrics.failure.is_none(), "{run:?}");
        // On the corner's machine: both axes moved (the sweep's point moves one).
        let machine = corner_machine(&args.corner, run.string).expect("physical");
        assert!(machine.mechanics.gripper.mass_kg > 1.5, "past the family's 1.5 kg");
        assert_ne!(run.metrics, sweep.metrics, "the gripper moved the figures");
    }
    let table = corner_markdown(&runs);
    assert!(table.contains("| tennis-synthetic | "), "{table}");
    assert!(table.contains("| tennis-poly | "), "{table}");
    assert!(table.contains("| **worst of 2** |") && table.contains("| 0 failed |"), "{table}");
    // A corner that names an axis twice is refused before anything runs.
    let twice = [(Axis::Inertia, 1.0), (Axis::Inertia, 0.0)];
    assert!(run_corner(&twice, 0, 1, None).metrics.failure.is_some());
}

#[test]
fn a_pull_re_runs_one_point_of_the_robustness_sweep() {
    let cli = parse(&["pull", "--axis", "backlash=1", "--string", "tennis-gut", "--tension", "20"]);
    let Some(Command::Pull(args)) = &cli.command else { panic!("pull") };
    let setup = taut::pull::setup(args).expect("one point of an axis is a physical machine");
    let kind = taut_sim::StringKind::TennisGut;
    assert_eq!(setup.twin, taut_sim::TwinConfig::on_axis(taut_sim::Axis::Backlash, 1.0, kind));
    assert!((setup.target_kgf - 20.0).abs() < 1e-9);
    assert!(setup.machine.contains("backlash 0.2000 mm"), "{}", setup.machine);
}
