//! `shellwarp eval`: run experiments (or single cases, or merge cases run elsewhere) and write CSVs,
//! charts and the Markdown summary.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Mutex;

use anyhow::{Context, bail};
use shellwarp::eval::{self, CaseId, runner::Event};

/// Arguments of `shellwarp eval`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Experiments: paper-fig6, paper-fig4, paper-perf, pareto, stability, auto-model, cubature, or all.\n\
    Spread a sweep over machines: `eval --plan EXPERIMENT...` prints one command per case; run them anywhere \
    (each writes DIR/cases/), then `eval --merge DIR... --out REPORT` draws the charts and summary."
)]
pub struct EvalArgs {
    /// Experiments to run (`all` for every one).
    #[arg(value_name = "EXPERIMENT")]
    experiments: Vec<String>,
    /// Output directory: per-case tables in DIR/cases/, one CSV per experiment, charts, README.md.
    #[arg(long, default_value = "report")]
    out: PathBuf,
    /// A smaller sweep (a few minutes for `all`).
    #[arg(long)]
    quick: bool,
    /// Cases run in parallel (timings are then shared-machine timings).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64))]
    jobs: u32,
    /// Print one `shellwarp eval --case ...` command per case of the experiments, and run nothing.
    #[arg(long, conflicts_with_all = ["case", "merge"])]
    plan: bool,
    /// Run only these cases (ids as `--plan` prints them) and write their tables to DIR/cases/.
    #[arg(long, value_name = "ID", conflicts_with = "merge")]
    case: Vec<String>,
    /// Merge the case tables found in these directories into --out (CSVs, charts, summary).
    #[arg(long, value_name = "DIR", num_args = 1..)]
    merge: Vec<PathBuf>,
}

/// Run the requested mode.
pub fn run(args: &EvalArgs) -> anyhow::Result<ExitCode> {
    if !args.merge.is_empty() {
        let sections = eval::merge(&args.merge, &args.out).context("merging")?;
        say!("{} experiment(s) → {}", sections.len(), args.out.join("README.md").display());
        return Ok(ExitCode::SUCCESS);
    }
    if !args.case.is_empty() {
        let cases: Vec<CaseId> = args.case.iter().map(|id| CaseId::parse(id)).collect::<Result<_, _>>()?;
        run_with_progress(&cases, args)?;
        return Ok(ExitCode::SUCCESS);
    }
    if args.experiments.is_empty() {
        bail!("name the experiments to run, or `all` (see `shellwarp eval --help`)");
    }
    let cases = eval::plan(&args.experiments, args.quick)?;
    if args.plan {
        let quick = if args.quick { " --quick" } else { "" };
        for c in &cases {
            say!("shellwarp eval --case '{}'{quick} --out '{}'", c.id(), args.out.display());
        }
        return Ok(ExitCode::SUCCESS);
    }
    // A failed case is reported after the others have run and the report is written without it.
    let ran = run_with_progress(&cases, args);
    let only = eval::chosen(&args.experiments)?;
    let merged = eval::merge_only(std::slice::from_ref(&args.out), &args.out, &only);
    ran?;
    let sections = merged.context("writing the report")?;
    let charts: usize = sections.iter().map(|s| s.charts.len()).sum();
    say!(
        "{} case(s), {} experiment(s), {charts} chart(s) → {}",
        cases.len(),
        sections.len(),
        args.out.join("README.md").display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Run cases with a progress bar naming the ones under way.
fn run_with_progress(cases: &[CaseId], args: &EvalArgs) -> anyhow::Result<()> {
    let bar = indicatif::ProgressBar::new(cases.len() as u64).with_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} cases  {wide_msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let running = Mutex::new(Vec::<String>::new());
    let events = |e: Event| {
        let mut r = running.lock().unwrap_or_else(|p| p.into_inner());
        match e {
            Event::Started(id) => r.push(id),
            Event::Finished(id) => {
                r.retain(|x| *x != id);
                bar.inc(1);
            }
        }
        bar.set_message(r.join(", "));
    };
    let result = eval::run_cases(cases, args.quick, &args.out, args.jobs as usize, &events);
    bar.finish_and_clear();
    result.context("running the cases")
}
