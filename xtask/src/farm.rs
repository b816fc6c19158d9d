//! `cargo xtask farm`: a render split into parts, each a separate `spectrace render --part K/M
//! --film` process, merged with `spectrace merge`, and compared byte for byte with one
//! `spectrace render` of all the samples. Prints the wall time of every part, of the merge
//! and of the single render, and the film files' size.
//!
//! Engines: `local` runs the parts as child processes on this machine (`--jobs` at a time);
//! `slurm` submits them as a job array to a Slurm cluster (`sbatch` on the PATH, e.g. the
//! single-node one of `examples/slurm/local-cluster.sh`) with the merge as a dependent job.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};

/// Where the parts run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Engine {
    /// Child processes on this machine.
    Local,
    /// A Slurm job array (`sbatch --array=1-M`) and a dependent merge job.
    Slurm,
}

/// Arguments of `farm`.
#[derive(Debug, clap::Args)]
pub(crate) struct FarmArgs {
    /// Where the parts run.
    #[arg(long, value_enum, default_value = "local")]
    engine: Engine,
    /// Scene file (relative to the workspace root).
    #[arg(long, default_value = "scenes/reference/cornell_box.json")]
    scene: PathBuf,
    /// Number of parts M.
    #[arg(long, default_value_t = 4)]
    parts: u32,
    /// Samples per pixel of the whole render.
    #[arg(long, default_value_t = 256)]
    spp: u32,
    /// Image width.
    #[arg(long, default_value_t = 128)]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 128)]
    height: u32,
    /// Integrator (`whitted-hall` or `path`).
    #[arg(long, default_value = "path")]
    integrator: String,
    /// Spectral mode.
    #[arg(long, default_value = "auto")]
    spectral: String,
    /// Also write and compare the spectral EXR (fixed wavelengths only).
    #[arg(long)]
    spectral_exr: bool,
    /// Parts running at once with the local engine (the machine's cores are shared by them).
    #[arg(long, default_value_t = 1)]
    jobs: usize,
    /// Worker threads of each part [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
    /// Folder for the films and images [default: target/farm].
    #[arg(long)]
    out: Option<PathBuf>,
    /// The spectrace binary [default: target/release/spectrace, built first].
    #[arg(long)]
    bin: Option<PathBuf>,
}

pub(crate) fn run(args: &FarmArgs) -> anyhow::Result<()> {
    let root = crate::project_root();
    let bin = match &args.bin {
        Some(b) => b.clone(),
        None => {
            let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
            let status = Command::new(cargo)
                .current_dir(&root)
                .args(["build", "--release", "-p", "cli"])
                .status()
                .context("running cargo build")?;
            if !status.success() {
                bail!("cargo build --release -p cli failed");
            }
            root.join("target/release/spectrace")
        }
    };
    let bin = std::fs::canonicalize(&bin).with_context(|| bin.display().to_string())?;
    let out = args.out.clone().unwrap_or_else(|| root.join("target/farm"));
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).with_context(|| out.display().to_string())?;
    let out = std::fs::canonicalize(&out)?;
    let scene = std::fs::canonicalize(root.join(&args.scene)).with_context(|| args.scene.display().to_string())?;
    let mut common: Vec<String> = vec![
        scene.display().to_string(),
        "--width".into(),
        args.width.to_string(),
        "--height".into(),
        args.height.to_string(),
        "--spp".into(),
        args.spp.to_string(),
        "--integrator".into(),
        args.integrator.clone(),
        "--spectral".into(),
        args.spectral.clone(),
        "--quiet".into(),
    ];
    if let Some(t) = args.threads {
        common.extend(["--threads".into(), t.to_string()]);
    }
    let m = args.parts;
    println!(
        "farm: {} {}x{} {} spp, {} {}, {m} parts, engine {:?}",
        args.scene.display(),
        args.width,
        args.height,
        args.spp,
        args.integrator,
        args.spectral,
        args.engine
    );

    // The reference: one process rendering every sample.
    let mut single = common.clone();
    single.extend(["-o".into(), "single.exr".into()]);
    if args.spectral_exr {
        single.extend(["--spectral-exr".into(), "single-spectral.exr".into()]);
    }
    let single_time = timed(&bin, &out, &single)?;
    println!("single render: {:.3} s", single_time.as_secs_f64());

    let mut part_args = common.clone();
    if args.spectral_exr {
        part_args.push("--spectral-film".into());
    }
    let mut merge: Vec<String> = vec!["merge".into()];
    merge.extend((1..=m).map(|k| format!("part{k}.film")));
    merge.extend(["-o".into(), "merged.exr".into()]);
    if args.spectral_exr {
        merge.extend(["--spectral-exr".into(), "merged-spectral.exr".into()]);
    }
    let (part_times, merge_time, wall) = match args.engine {
        Engine::Local => run_local(&bin, &out, &part_args, &merge, m, args.jobs.max(1))?,
        Engine::Slurm => {
            // An existing cluster (SLURM_CONF set), or a single-node one started for this run.
            if std::env::var_os("SLURM_CONF").is_some() {
                run_slurm(&bin, &out, &part_args, &merge, m, None)?
            } else {
                let script = root.join("examples/slurm/local-cluster.sh");
                let state = out.join("slurm");
                let t = Instant::now();
                let status = Command::new("sh").arg(&script).arg("start").arg(&state).status()?;
                if !status.success() {
                    bail!("{} start failed (apt-get install slurmctld slurmd slurm-client munge)", script.display());
                }
                println!("slurm: single-node cluster up in {:.1} s", t.elapsed().as_secs_f64());
                let result = run_slurm(&bin, &out, &part_args, &merge, m, Some(&state.join("slurm.conf")));
                let _ = Command::new("sh").arg(&script).arg("stop").arg(&state).status();
                result?
            }
        }
    };
    let parts_total: f64 = part_times.iter().map(Duration::as_secs_f64).sum();
    for (k, t) in part_times.iter().enumerate() {
        println!("part {}/{m}: {:.3} s", k + 1, t.as_secs_f64());
    }
    let film_bytes: u64 =
        (1..=m).filter_map(|k| std::fs::metadata(out.join(format!("part{k}.film"))).ok()).map(|x| x.len()).sum();
    println!(
        "film files: {m} x {:.3} MB = {:.3} MB ({} bytes each)",
        film_bytes as f64 / f64::from(m) / 1e6,
        film_bytes as f64 / 1e6,
        film_bytes / u64::from(m)
    );
    println!("merge (read + check + merge + write images, whole process): {:.3} s", merge_time.as_secs_f64());
    println!(
        "parts summed {:.3} s + merge {:.3} s = {:.3} s vs single {:.3} s: overhead {:+.2} %; merge alone {:.2} % of the render; \
         wall time from first part to merged image {:.3} s (speed-up {:.2}x)",
        parts_total,
        merge_time.as_secs_f64(),
        parts_total + merge_time.as_secs_f64(),
        single_time.as_secs_f64(),
        100.0 * (parts_total + merge_time.as_secs_f64() - single_time.as_secs_f64()) / single_time.as_secs_f64(),
        100.0 * merge_time.as_secs_f64() / single_time.as_secs_f64(),
        wall.as_secs_f64(),
        single_time.as_secs_f64() / wall.as_secs_f64()
    );
    let mut pairs = vec![("single.exr", "merged.exr"), ("single.png", "merged.png")];
    if args.spectral_exr {
        pairs.push(("single-spectral.exr", "merged-spectral.exr"));
    }
    let mut all_same = true;
    for (a, b) in pairs {
        let (x, y) = (std::fs::read(out.join(a))?, std::fs::read(out.join(b))?);
        let same = x == y;
        all_same &= same;
        println!("{a} vs {b}: {} ({} bytes)", if same { "identical" } else { "DIFFERENT" }, x.len());
    }
    if !all_same {
        bail!("the merged images differ from the single render");
    }
    println!("farm: merged == single render, byte for byte");
    Ok(())
}

/// Run `bin args` in `dir`; it must succeed. Its wall time.
fn timed(bin: &Path, dir: &Path, args: &[String]) -> anyhow::Result<Duration> {
    let start = Instant::now();
    let mut full = vec!["render".to_owned()];
    if args.first().map(String::as_str) == Some("merge") {
        full.clear();
    }
    full.extend(args.iter().cloned());
    let output = Command::new(bin).current_dir(dir).args(&full).output()?;
    if !output.status.success() {
        bail!("{} {}: {}", bin.display(), full.join(" "), String::from_utf8_lossy(&output.stderr));
    }
    Ok(start.elapsed())
}

type Timings = (Vec<Duration>, Duration, Duration);

fn run_local(
    bin: &Path,
    dir: &Path,
    part_args: &[String],
    merge: &[String],
    m: u32,
    jobs: usize,
) -> anyhow::Result<Timings> {
    let start = Instant::now();
    let mut times = vec![Duration::ZERO; m as usize];
    let ks: Vec<u32> = (1..=m).collect();
    for chunk in ks.chunks(jobs) {
        let children = chunk
            .iter()
            .map(|&k| {
                let mut a = part_args.to_vec();
                a.extend(["--part".into(), format!("{k}/{m}"), "--film".into(), format!("part{k}.film")]);
                let t = Instant::now();
                Command::new(bin).current_dir(dir).arg("render").args(&a).spawn().map(|c| (k, t, c))
            })
            .collect::<std::io::Result<Vec<_>>>()?;
        for (k, t, child) in children {
            let output = child.wait_with_output()?;
            if !output.status.success() {
                bail!("part {k}/{m} failed");
            }
            times[k as usize - 1] = t.elapsed();
        }
    }
    let merge_time = timed(bin, dir, merge)?;
    Ok((times, merge_time, start.elapsed()))
}

fn run_slurm(
    bin: &Path,
    dir: &Path,
    part_args: &[String],
    merge: &[String],
    m: u32,
    conf: Option<&Path>,
) -> anyhow::Result<Timings> {
    let slurm = |program: &str| {
        let mut c = Command::new(program);
        if let Some(conf) = conf {
            c.env("SLURM_CONF", conf);
        }
        c
    };
    let quote = |s: &str| format!("'{}'", s.replace('\'', r"'\''"));
    let args = part_args.iter().map(|a| quote(a)).collect::<Vec<_>>().join(" ");
    let bin_q = quote(&bin.display().to_string());
    // Each task records its own wall time, as the local engine measures it.
    let array = format!(
        "#!/bin/sh\n#SBATCH --job-name=spectrace-part\n#SBATCH --output=part-%a.log\n\
         start=$(date +%s.%N)\n\
         {bin_q} render {args} --part \"$SLURM_ARRAY_TASK_ID/{m}\" --film \"part$SLURM_ARRAY_TASK_ID.film\" || exit 1\n\
         end=$(date +%s.%N)\necho \"$start $end\" > \"part$SLURM_ARRAY_TASK_ID.time\"\n"
    );
    let merge_args = merge.iter().map(|a| quote(a)).collect::<Vec<_>>().join(" ");
    let merge_script = format!(
        "#!/bin/sh\n#SBATCH --job-name=spectrace-merge\n#SBATCH --output=merge.log\n\
         start=$(date +%s.%N)\n{bin_q} {merge_args} || exit 1\nend=$(date +%s.%N)\necho \"$start $end\" > merge.time\n"
    );
    std::fs::write(dir.join("part.sbatch"), array)?;
    std::fs::write(dir.join("merge.sbatch"), merge_script)?;
    let start = Instant::now();
    let sbatch = |extra: &[&str]| -> anyhow::Result<String> {
        let output =
            slurm("sbatch").current_dir(dir).arg("--parsable").args(extra).output().context("running sbatch")?;
        if !output.status.success() {
            bail!("sbatch {extra:?}: {}", String::from_utf8_lossy(&output.stderr));
        }
        Ok(String::from_utf8_lossy(&output.stdout).trim().split(';').next().unwrap_or_default().to_owned())
    };
    let array_id = sbatch(&[&format!("--array=1-{m}"), "--chdir", &dir.display().to_string(), "part.sbatch"])?;
    let merge_id =
        sbatch(&[&format!("--dependency=afterok:{array_id}"), "--chdir", &dir.display().to_string(), "merge.sbatch"])?;
    println!("slurm: array job {array_id} ({m} tasks), merge job {merge_id} after it");
    // Wait for the merge job to leave the queue.
    let deadline = Instant::now() + Duration::from_secs(3600);
    loop {
        let q = slurm("squeue").args(["-h", "-j", &format!("{array_id},{merge_id}")]).output()?;
        if String::from_utf8_lossy(&q.stdout).trim().is_empty() {
            break;
        }
        if Instant::now() > deadline {
            bail!("the Slurm jobs did not finish within an hour");
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    let wall = start.elapsed();
    let read_time = |name: &str| -> anyhow::Result<Duration> {
        let text = std::fs::read_to_string(dir.join(name))
            .with_context(|| format!("{name}: the job did not finish (see its .log)"))?;
        let v: Vec<f64> = text.split_whitespace().filter_map(|t| t.parse().ok()).collect();
        match v.as_slice() {
            [a, b] => Ok(Duration::from_secs_f64((b - a).max(0.0))),
            _ => bail!("{name}: `{text}`"),
        }
    };
    let times = (1..=m).map(|k| read_time(&format!("part{k}.time"))).collect::<anyhow::Result<Vec<_>>>()?;
    Ok((times, read_time("merge.time")?, wall))
}
