//! `hdrflow batch`: arguments, progress and the report files; the work is in `crate::batch`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use clap::Args;
use indicatif::ProgressBar;

use super::batch_progress::{items_style, Progress};
use super::{slurm, PersistArg};
use crate::batch::{self, Axis, BatchOptions, Item, ItemStatus};
use crate::engine::cache::store::{default_max_bytes, write_atomic, DEFAULT_LIMIT_BYTES};
use crate::engine::cache::CacheStore;
use crate::engine::registry::Registry;

#[derive(Args)]
pub(crate) struct BatchArgs {
    /// The pipeline file (RON).
    graph: PathBuf,
    /// One item per value: NODE.FIELD=GLOB (matching files, sorted) or NODE.FIELD=V1,V2,...
    /// (repeatable; several form the cross product).
    #[arg(long = "over", value_name = "NODE.FIELD=GLOB_OR_LIST")]
    over: Vec<String>,
    /// A parameter sweep: NODE.FIELD=V1,V2,... (RON values, as in `run --set`; repeatable).
    #[arg(long = "sweep", value_name = "NODE.FIELD=V1,V2,...")]
    sweep: Vec<String>,
    /// Pair the --over/--sweep values (equal lengths) instead of their cross product.
    #[arg(long)]
    zip: bool,
    /// Output folder; each item writes into DIR/TEMPLATE/.
    #[arg(long)]
    out: PathBuf,
    /// Item folder template: {stem}, {name}, {index}, {NODE.FIELD}. Default: {stem} of the first
    /// --over, then FIELD={NODE.FIELD} per other axis (e.g. grace/count=256).
    #[arg(long, value_name = "TEMPLATE")]
    item_dir: Option<String>,
    /// Run only the items whose index is congruent to I mod N (0 <= I < N).
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Worker threads in all; up to this many items run at once, each on threads/items of
    /// them. 0 or absent: one per core.
    #[arg(long)]
    jobs: Option<usize>,
    /// Cache folder (default: $HDRFLOW_CACHE_DIR, $XDG_CACHE_HOME/hdrflow or ~/.cache/hdrflow).
    #[arg(long)]
    cache_dir: Option<PathBuf>,
    /// Keep the cache folder within this many MiB during the batch: after each item, least
    /// recently used entries are pruned, sparing those of running items and the shared entries
    /// that items still to run will load.
    #[arg(long, default_value_t = DEFAULT_LIMIT_BYTES >> 20)]
    cache_limit_mb: u64,
    /// Which computed results go into the cache (as for `run`): `auto` or `all`.
    #[arg(long, value_enum, default_value_t = PersistArg::Auto)]
    persist: PersistArg,
    /// Write one JSON row per item to FILE, and the same rows to DIR/batch.csv
    /// (DIR/batch.I-of-N.csv with --shard); when the items produce metrics, also DIR/metrics.csv
    /// (a row per item and metrics node) and DIR/summary.csv and summary.md (each metric's mean
    /// and 95% interval).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Run every item even after one fails (default: start no new item after a failure).
    #[arg(long)]
    keep_going: bool,
    /// List the items and their folders; run nothing.
    #[arg(long)]
    plan: bool,
    /// Print only errors.
    #[arg(long, short)]
    quiet: bool,
    /// Run nothing: write an `sbatch` script FILE running the batch as a Slurm job array (one
    /// element per shard, reports in DIR/shards/), and FILE.resubmit, which resubmits the shards
    /// that did not finish. Cache and output folders must be on a filesystem every node sees.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["shard", "report", "plan", "failed_shards"])]
    emit_slurm: Option<PathBuf>,
    /// With --emit-slurm: the number of shards (array elements). Default: the number of items,
    /// at most 64.
    #[arg(long, value_name = "N", requires = "emit_slurm")]
    shards: Option<usize>,
    /// With --emit-slurm: an `#SBATCH --KEY=VALUE` line (or `--KEY` for KEY alone), replacing the
    /// default line with the same key (array, job-name, cpus-per-task, output) or added (repeatable).
    #[arg(long, value_name = "KEY=VALUE", requires = "emit_slurm")]
    slurm_arg: Vec<String>,
    /// Run nothing: print the shards (of N) whose report DIR/shards/shard-I-of-N.json is missing,
    /// lacks an item or has an item neither computed nor cached, as a comma list for
    /// `sbatch --array=LIST` (empty when every shard finished).
    #[arg(long, value_name = "N", conflicts_with_all = ["shard", "report", "plan"])]
    failed_shards: Option<usize>,
}

fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let err = || format!("--shard {s:?}: expected I/N with 0 <= I < N");
    let (i, n) = s.split_once('/').ok_or_else(err)?;
    let (i, n): (usize, usize) = (i.trim().parse().map_err(|_| err())?, n.trim().parse().map_err(|_| err())?);
    if n == 0 || i >= n {
        return Err(err());
    }
    Ok((i, n))
}

pub(crate) fn batch(registry: &Registry, args: &BatchArgs) -> ExitCode {
    let usage = |e: String| {
        eprintln!("error: {e}");
        ExitCode::from(2)
    };
    let mut axes = Vec::new();
    for s in &args.over {
        match Axis::parse(s, true) {
            Ok(a) => axes.push(a),
            Err(e) => return usage(e),
        }
    }
    for s in &args.sweep {
        match Axis::parse(s, false) {
            Ok(a) => axes.push(a),
            Err(e) => return usage(e),
        }
    }
    let mut items = match batch::items(&axes, args.zip, args.item_dir.as_deref()) {
        Ok(i) => i,
        Err(e) => return usage(e),
    };
    let total_items = items.len();
    if let Some(n) = args.failed_shards {
        if n == 0 {
            return usage("--failed-shards 0: expected N >= 1".to_string());
        }
        let mut failed = Vec::new();
        for i in 0..n {
            if let Some(why) = slurm::shard_problem(&items, &args.out, i, n) {
                if !args.quiet {
                    eprintln!("shard {i} of {n} not finished: {why}");
                }
                failed.push(i);
            }
        }
        if !args.quiet {
            eprintln!("{} of {n} shards not finished", failed.len());
        }
        outln!("{}", slurm::array_list(&failed));
        return ExitCode::SUCCESS;
    }
    let shard = match args.shard.as_deref().map(parse_shard).transpose() {
        Ok(s) => s,
        Err(e) => return usage(e),
    };
    if let Some((i, n)) = shard {
        items = batch::shard(items, i, n);
    }
    let pipelines = match batch::validate(registry, &args.graph, &items) {
        Ok(p) => p,
        Err(errors) => {
            for e in &errors {
                eprintln!("error: {e}");
            }
            eprintln!(
                "{} error{} in the batch's items; nothing was run",
                errors.len(),
                if errors.len() == 1 { "" } else { "s" }
            );
            return ExitCode::from(2);
        }
    };
    if let Some(file) = &args.emit_slurm {
        return emit_slurm(file, total_items, args);
    }
    if args.plan {
        print_plan(&items, total_items, args);
        return ExitCode::SUCCESS;
    }
    if let Err(e) = crate::engine::scheduler::check_output_dir(&args.out) {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    let terminal = std::io::stderr().is_terminal() && !args.quiet;
    let bar = terminal.then(|| {
        let bar = ProgressBar::new(items.len() as u64);
        bar.set_style(items_style());
        bar
    });
    let progress = Progress {
        total: items.len(),
        quiet: args.quiet,
        bar,
        counts: Mutex::new([0; 3]),
        start: Instant::now(),
        sharing: AtomicBool::new(false),
    };
    let cache =
        CacheStore::new(args.cache_dir.clone().unwrap_or_else(CacheStore::default_dir), args.cache_limit_mb << 20)
            .with_policy(args.persist.into());
    // Ctrl-C: no further item starts, the running ones finish and the report is written with
    // the rest marked "not started"; a second Ctrl-C quits at once (exit 130).
    static CANCEL: AtomicBool = AtomicBool::new(false);
    let bar_for_handler = progress.bar.clone();
    if let Err(e) = ctrlc::set_handler(move || {
        if CANCEL.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
        let line = "interrupted: finishing the running items, then writing the report (Ctrl-C again to quit now)";
        match &bar_for_handler {
            Some(bar) => bar.println(line),
            None => eprintln!("{line}"),
        }
    }) {
        eprintln!("warning: Ctrl-C will not stop the batch cleanly: {e}");
    }
    let options = BatchOptions {
        out_dir: args.out.clone(),
        cache: cache.clone(),
        cache_limit_bytes: cache_limit_bytes(args.cache_limit_mb),
        jobs: args.jobs,
        keep_going: args.keep_going,
        observer: &progress,
        cancel: Some(&CANCEL),
    };
    let outcome = batch::run(&items, &pipelines, &options);
    if let Some(bar) = &progress.bar {
        bar.finish_and_clear();
    }
    let failed = outcome.rows.iter().filter(|r| r.status == ItemStatus::Failed).count();
    let count = |s: ItemStatus| outcome.rows.iter().filter(|r| r.status == s).count();
    if !args.quiet {
        let secs = progress.start.elapsed().as_secs_f64();
        eprintln!(
            "{} items: {} computed, {} cached, {} failed, {} not started; {:.2} s ({:.2} items/s); {} node evaluations for {} items x nodes ({} for nodes shared by several items)",
            items.len(),
            count(ItemStatus::Computed),
            count(ItemStatus::Cached),
            failed,
            outcome.not_started,
            secs,
            outcome.rows.len() as f64 / secs.max(1e-9),
            outcome.evaluations,
            outcome.item_nodes,
            outcome.shared_evaluations,
        );
    }
    for r in outcome.rows.iter().filter(|r| r.status == ItemStatus::Failed) {
        eprintln!("error: item {:?} failed: {}", r.item.dir, r.error.as_deref().unwrap_or(""));
    }
    if let Some(path) = &args.report {
        let mut rows = batch::json_rows(&outcome.rows);
        // Items never started (after a failure, without --keep-going) get a row too, so the
        // report has a status for every item of the shard.
        if let Some(rows) = rows.as_array_mut() {
            for it in items.iter().filter(|it| !outcome.rows.iter().any(|r| r.item.index == it.index)) {
                let values: serde_json::Map<String, serde_json::Value> =
                    it.values.iter().map(|(k, v)| (k.clone(), v.clone().into())).collect();
                rows.push(serde_json::json!({
                    "item": it.dir, "index": it.index, "values": values, "status": "not started",
                    "ms": 0.0, "error": null, "evaluations": 0, "metrics": {},
                }));
            }
            rows.sort_by_key(|r| r["index"].as_u64());
        }
        let json = serde_json::to_string_pretty(&rows).expect("rows serialise");
        let csv_name = match shard {
            Some((i, n)) => format!("batch.{i}-of-{n}.csv"),
            None => "batch.csv".to_string(),
        };
        let csv_path = args.out.join(csv_name);
        let mut files = vec![(path.clone(), json.into_bytes()), (csv_path, batch::csv(&outcome.rows).into_bytes())];
        // The metrics by node and their summary (batch::summary), when the items produced any.
        let summary = batch::summarise(&outcome.rows);
        if let Some(metrics) = batch::metrics_csv(&outcome.rows) {
            let named = |stem: &str, ext: &str| match shard {
                Some((i, n)) => args.out.join(format!("{stem}.{i}-of-{n}.{ext}")),
                None => args.out.join(format!("{stem}.{ext}")),
            };
            let table = batch::summary_markdown(&summary);
            if !args.quiet {
                println!("{}: the mean of each metric and its 95% interval\n{table}", named("summary", "md").display());
            }
            files.push((named("metrics", "csv"), metrics.into_bytes()));
            files.push((named("summary", "csv"), batch::summary_csv(&summary).into_bytes()));
            files.push((named("summary", "md"), table.into_bytes()));
        }
        for (p, bytes) in files {
            if let Err(e) = write_atomic(&p, &bytes) {
                eprintln!("error: writing report {}: {e}", p.display());
                return ExitCode::from(1);
            }
        }
    }
    if outcome.cancelled {
        eprintln!(
            "interrupted: {} of {} items finished; run the same command again to resume (finished items come from the cache){}",
            outcome.rows.len(),
            items.len(),
            args.report.as_ref().map_or(String::new(), |r| format!("; {} marks the rest \"not started\"", r.display()))
        );
        return ExitCode::from(130);
    }
    if cache.root().is_dir() {
        if let Err(e) = cache.prune(cache_limit_bytes(args.cache_limit_mb).min(default_max_bytes())) {
            eprintln!("warning: cache pruning: {e}");
        }
    }
    if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

fn print_plan(items: &[Item], total: usize, args: &BatchArgs) {
    outln!("{:<6} {:<40} values", "index", "folder");
    for it in items {
        let values: Vec<String> = it.values.iter().map(|(k, v)| format!("{k}={v}")).collect();
        outln!("{:<6} {:<40} {}", it.index, args.out.join(&it.dir).display(), values.join(" "));
    }
    outln!("{} of {} items (planned; nothing was run)", items.len(), total);
}

/// `--emit-slurm FILE`: writes the `sbatch` script and FILE.resubmit (mode 755), creates
/// DIR/slurm and DIR/shards (Slurm does not create the folder of `--output`).
fn emit_slurm(file: &std::path::Path, total_items: usize, args: &BatchArgs) -> ExitCode {
    let fail = |e: String| {
        eprintln!("error: {e}");
        ExitCode::from(1)
    };
    let shards = args.shards.unwrap_or(total_items.clamp(1, 64));
    if shards == 0 {
        eprintln!("error: --shards 0: expected N >= 1");
        return ExitCode::from(2);
    }
    let abs = |p: &std::path::Path| std::path::absolute(p).map_err(|e| format!("{}: {e}", p.display()));
    let paths = (|| -> Result<_, String> {
        let exe = std::env::current_exe().map_err(|e| format!("the hdrflow executable's path: {e}"))?;
        let cwd = std::env::current_dir().map_err(|e| format!("the working folder: {e}"))?;
        let cache = args.cache_dir.clone().unwrap_or_else(CacheStore::default_dir);
        Ok((exe, cwd, abs(&args.graph)?, abs(&args.out)?, abs(&cache)?, abs(file)?))
    })();
    let (exe, cwd, graph, out, cache, file) = match paths {
        Ok(p) => p,
        Err(e) => return fail(e),
    };
    let mut options = Vec::new();
    for o in &args.over {
        options.extend(["--over".to_string(), o.clone()]);
    }
    for o in &args.sweep {
        options.extend(["--sweep".to_string(), o.clone()]);
    }
    if args.zip {
        options.push("--zip".into());
    }
    if let Some(t) = &args.item_dir {
        options.extend(["--item-dir".to_string(), t.clone()]);
    }
    if let Some(j) = args.jobs {
        options.extend(["--jobs".to_string(), j.to_string()]);
    }
    options.extend(["--cache-dir".to_string(), cache.to_string_lossy().into_owned()]);
    options.extend(["--cache-limit-mb".to_string(), args.cache_limit_mb.to_string()]);
    if args.persist == PersistArg::All {
        options.extend(["--persist".to_string(), "all".to_string()]);
    }
    if args.keep_going {
        options.push("--keep-going".into());
    }
    let cpus = args.jobs.filter(|&j| j > 0).unwrap_or(1);
    let lines = match slurm::apply_slurm_args(slurm::default_lines(shards, cpus, &out), &args.slurm_arg) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let spec = slurm::ScriptSpec { exe, cwd, graph, options, out: out.clone(), shards, lines };
    for d in [out.join("slurm"), out.join("shards")] {
        if let Err(e) = std::fs::create_dir_all(&d) {
            return fail(format!("creating {}: {e}", d.display()));
        }
    }
    let mut resubmit = file.clone().into_os_string();
    resubmit.push(".resubmit");
    let resubmit = PathBuf::from(resubmit);
    for (p, text) in [(&file, spec.sbatch_script()), (&resubmit, spec.resubmit_script(&file))] {
        if let Err(e) = write_atomic(p, text.as_bytes()) {
            return fail(format!("writing {}: {e}", p.display()));
        }
        use std::os::unix::fs::PermissionsExt;
        if let Err(e) = std::fs::set_permissions(p, std::fs::Permissions::from_mode(0o755)) {
            return fail(format!("making {} executable: {e}", p.display()));
        }
    }
    if !args.quiet {
        eprintln!(
            "wrote {} ({total_items} items in {shards} shards; submit with `sbatch {}`) and {} (resubmits unfinished shards)",
            file.display(),
            file.display(),
            resubmit.display()
        );
    }
    ExitCode::SUCCESS
}

/// `--cache-limit-mb` in bytes (saturating: a huge value means no limit, not an overflow).
fn cache_limit_bytes(mb: u64) -> u64 {
    mb.saturating_mul(1 << 20)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::batch::BatchObserver;
    use crate::cli::testing::{exit_code, parse_error};

    #[test]
    fn argument_errors() {
        assert_eq!(parse_error(&["batch"]).0, clap::error::ErrorKind::MissingRequiredArgument);
        for bad in ["3/2", "1", "a/b", "0/0"] {
            assert!(parse_shard(bad).unwrap_err().contains("expected I/N with 0 <= I < N"), "{bad}");
        }
        assert_eq!(parse_shard("1/3"), Ok((1, 3)));
        // No --over or --sweep: a usage error (2) before anything runs.
        let dir = tempfile::tempdir().unwrap();
        let g = dir.path().join("g.ron");
        std::fs::write(&g, r#"(nodes: { "env": LoadHdr(path: "builtin:sky") })"#).unwrap();
        let out = dir.path().join("out");
        let code = exit_code(&["batch", g.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet"]);
        assert_eq!(code, ExitCode::from(2));
    }

    /// Issue 25.6: through the shared phase the terminal bar says what it is doing ("shared
    /// nodes 12/101"), not `0/6 items ... eta 0s`, and goes back to the item count after it.
    #[test]
    fn the_bar_counts_shared_nodes_then_items() {
        let progress = Progress {
            total: 6,
            quiet: false,
            bar: Some(ProgressBar::hidden()),
            counts: Mutex::new([0; 3]),
            start: Instant::now(),
            sharing: AtomicBool::new(false),
        };
        let bar = progress.bar.as_ref().unwrap();
        progress.shared_phase(101);
        assert!(bar.message().starts_with("shared nodes 0/101"), "{}", bar.message());
        progress.shared_progress(12, 101);
        assert!(bar.message().starts_with("shared nodes 12/101"), "{}", bar.message());
        progress.shared_progress(101, 101);
        assert_eq!(bar.message(), "0 computed, 0 cached, 0 failed, 6 left");
        // Once back, a late event does not switch the bar again.
        let item = Item { index: 0, dir: "m0".into(), values: Vec::new() };
        progress.item_started(&item);
        assert_eq!(bar.message(), "0 computed, 0 cached, 0 failed, 6 left");
    }
}
