//! `rtmesh optimize`: the main job, for one file or a whole library.

use crate::args::{load, parse_size_or_zero, CameraArg};
use crate::output::{json_line, refuse_overwriting_input, steps_bar, write_mesh};
use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use rtmesh::optimize::html::{Header, Pictures};
use rtmesh::optimize::{MeasureOptions, OptimizeOptions, OptimizeReport, Optimized, Target};
use rtmesh::pair::PairMethod;
use rtmesh::progress::Progress;
use rtmesh::repair::Degenerate;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Prepare meshes for ray tracing, write them with everything kept, and prove the gain.
///
/// For each input: read; lint; the safe repairs (weld identical vertices, drop
/// degenerate triangles and exact copies, split scattered geometries and merge
/// overlapping ones where probe rays measure a gain, split alpha-tested from opaque
/// triangles: each can be turned off); prepare for the target (pairs: triangles that
/// share an edge by vertex index, by the best of the input order, sah-max and
/// window:2, written as consecutive triangles that Embree's,
/// HIPRT's and GPURT's first-fit pairers recover exactly, with the explicit pair list
/// beside the output as OUT.pairs.json); write OUT in the input's format (or the one
/// OUT's extension or --format names) with every attribute, material and node kept;
/// then trace primary, diffuse and shadow rays through the input and the output,
/// alternating rounds, and report box and triangle tests per ray, Mrays/s, BVH and
/// geometry bytes, build time, and whether every ray hits the same input triangle.
///
/// IN may be many files or folders (searched for .obj, .ply, .gltf, .glb, .stl); OUT is
/// then a folder that mirrors them. Small files run in parallel, one per core (each
/// traced on one thread); large ones one at a time on every core. One bad file is
/// reported and does not stop the others; the exit status is 1 if any failed. Farm
/// schedulers can spread a library over machines by giving each its share of IN.
#[derive(clap::Args)]
pub struct Args {
    /// Mesh files or folders, or builtin:NAME.
    #[arg(required = true, value_name = "IN")]
    inputs: Vec<String>,
    /// Where to write: a file for one input (its extension picks the format), else a
    /// folder that mirrors the inputs. Not needed with --dry-run.
    #[arg(short, long, value_name = "OUT", required_unless_present = "dry_run")]
    output: Option<PathBuf>,
    /// What to prepare for: pairs, triangles (repairs only), strips (triangles in
    /// Strip-RT strip order, the strip table beside OUT as OUT.strips.json) or clusters
    /// (triangles in cluster order, the cluster table as OUT.clusters.json). The
    /// measurement traces strips and clusters through triangle leaves.
    #[arg(long, default_value = "pairs")]
    target: Target,
    /// Write the HTML report here: a file for one input, else a folder (one report per
    /// input, mirrored, and index.html).
    #[arg(long, value_name = "PATH")]
    report: Option<PathBuf>,
    /// Print one JSON line per file (then a summary table on standard error).
    #[arg(long)]
    json: bool,
    /// Write no mesh, only the report (and the JSON).
    #[arg(long)]
    dry_run: bool,
    /// Output format for every file of a batch: obj, ply, gltf, glb or stl (default:
    /// each input's own).
    #[arg(long, value_name = "EXT")]
    format: Option<String>,
    /// Do not weld identical vertices.
    #[arg(long)]
    no_weld: bool,
    /// Keep degenerate triangles (repeated corners, zero area).
    #[arg(long)]
    no_degenerate: bool,
    /// Keep exact copies of earlier triangles.
    #[arg(long)]
    no_duplicates: bool,
    /// Do not split scattered geometries into pieces.
    #[arg(long)]
    no_split_scattered: bool,
    /// Do not merge overlapping geometries.
    #[arg(long)]
    no_merge_overlapping: bool,
    /// Do not split alpha-tested from opaque triangles.
    #[arg(long)]
    no_split_alpha: bool,
    /// Pairing method: sah, sah-compressed, window:N, sah-max or max. By default,
    /// whichever of the input's own order, sah-max and window:2 pairs the most
    /// triangles (sah-max rather than sah: 0.91x the BVH bytes at the same speed).
    #[arg(long)]
    pair_method: Option<PairMethod>,
    /// Image size of the measurement's primary rays (0x0 skips the measurement). Where
    /// tracing would take over 2 s per comparison, fewer rays are traced.
    #[arg(long, default_value = "512x512", value_parser = parse_size_or_zero)]
    size: (usize, usize),
    /// Alternating timed rounds of the measurement (medians).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    #[command(flatten)]
    camera: CameraArg,
    /// Files optimized at once, each traced on one thread (0: one per core for files
    /// under 8 MB, larger ones one at a time on every core). --jobs 1 runs every file
    /// alone on every core, for the steadiest Mrays/s.
    #[arg(long, default_value_t = 0)]
    jobs: usize,
}

/// Mesh file extensions a folder is searched for.
const MESH_EXTENSIONS: [&str; 5] = ["obj", "ply", "gltf", "glb", "stl"];

/// Files at or above this size run one at a time on every core.
const LARGE_FILE_BYTES: u64 = 8 << 20;

/// One input and where its results go.
#[derive(Clone, Debug)]
pub struct Job {
    /// The input as given (a path, or builtin:NAME).
    pub input: String,
    /// The output mesh file.
    pub output: Option<PathBuf>,
    /// The HTML report.
    pub report: Option<PathBuf>,
    /// Input size in bytes (0 for built-in scenes).
    bytes: u64,
}

/// What the command does to every job.
pub struct Settings {
    /// The library's options.
    pub options: OptimizeOptions,
    /// Write no mesh.
    pub dry_run: bool,
    /// JSON lines.
    pub json: bool,
    /// Picture size of the HTML report.
    pub picture_size: (usize, usize),
    /// Files at once (0: one per core for small files).
    pub jobs: usize,
}

/// One file's result: the line of `--json`.
#[derive(Serialize)]
pub struct FileReport {
    input: String,
    output: Option<PathBuf>,
    report: Option<PathBuf>,
    /// The explicit pair list beside the output (target pairs).
    pairs_file: Option<PathBuf>,
    /// The strip or cluster table beside the output (`--target strips|clusters`).
    #[serde(skip_serializing_if = "Option::is_none")]
    sequences_file: Option<PathBuf>,
    /// The files the output refers to (material libraries, textures), copied beside it.
    side_files: Vec<PathBuf>,
    /// What the output's format cannot hold and the output goes without (an output in
    /// another format than the input), in words.
    not_held: Vec<String>,
    /// What the input holds that rtmesh does not read (an OBJ's lines and points, a
    /// PLY's other elements), so that the output goes without it, in words.
    not_read: Vec<String>,
    ok: bool,
    error: Option<String>,
    /// Wall-clock seconds for this file, reading and writing included.
    seconds: f64,
    /// The library's report (with its own `rtmesh_version` and `schema`; a failed
    /// file's line is stamped like every other report).
    #[serde(flatten)]
    optimize: Option<OptimizeReport>,
}

/// Optimize every input.
pub fn run(args: Args) -> Result<()> {
    let jobs = plan(&args)?;
    let mut options = OptimizeOptions {
        target: args.target,
        pair_method: args.pair_method,
        measure: (args.size.0 > 0).then_some(MeasureOptions {
            size: args.size,
            runs: args.runs,
            view: args.camera.view,
        }),
        ..OptimizeOptions::default()
    };
    let repair = &mut options.repair;
    repair.weld = !args.no_weld;
    repair.degenerate = if args.no_degenerate {
        Degenerate::Keep
    } else {
        Degenerate::Remove
    };
    repair.remove_duplicates = !args.no_duplicates;
    repair.split_scattered = !args.no_split_scattered;
    repair.merge_overlapping = !args.no_merge_overlapping;
    repair.split_alpha = !args.no_split_alpha;
    let settings = Settings {
        options,
        dry_run: args.dry_run,
        json: args.json,
        picture_size: (480, 360),
        jobs: args.jobs,
    };
    let index = (jobs.len() > 1)
        .then_some(args.report.as_ref())
        .flatten()
        .map(|dir| dir.join("index.html"));
    run_jobs(&jobs, &settings, index.as_deref())
}

/// The jobs of the command line: every input file, with its output and report paths.
fn plan(args: &Args) -> Result<Vec<Job>> {
    // (input, path relative to OUT) for every file.
    let mut files: Vec<(String, PathBuf, u64)> = Vec::new();
    // A folder's files go into a folder of the same shape, however many it holds.
    let mut from_folder = false;
    // OUT and the reports' folder may lie inside an input folder: what is in them are
    // results, not inputs (else each run would also optimize the last run's output).
    let results: Vec<PathBuf> = [&args.output, &args.report]
        .into_iter()
        .flatten()
        .filter_map(|folder| std::fs::canonicalize(folder).ok())
        .collect();
    for input in &args.inputs {
        if let Some(name) = input.strip_prefix("builtin:") {
            files.push((input.clone(), PathBuf::from(format!("{name}.glb")), 0));
            continue;
        }
        let path = Path::new(input);
        if path.is_dir() {
            from_folder = true;
            let mut found = Vec::new();
            walk(path, &results, &mut found)
                .with_context(|| format!("listing {}", path.display()))?;
            found.sort();
            if found.is_empty() {
                bail!(
                    "{}: no mesh files (.obj, .ply, .gltf, .glb, .stl) in this folder",
                    path.display()
                );
            }
            for file in found {
                let relative = file.strip_prefix(path).unwrap_or(&file).to_owned();
                let bytes = std::fs::metadata(&file).map_or(0, |m| m.len());
                files.push((file.to_string_lossy().into_owned(), relative, bytes));
            }
        } else {
            let name = path.file_name().map(PathBuf::from).unwrap_or_default();
            let bytes = std::fs::metadata(path).map_or(0, |m| m.len());
            files.push((input.clone(), name, bytes));
        }
    }
    let single = files.len() == 1
        && !from_folder
        && !args
            .output
            .as_ref()
            .is_some_and(|o| o.is_dir() || o.as_os_str().to_string_lossy().ends_with('/'));
    if !single {
        refuse_file_names_for_folders(args, files.len())?;
    }
    let with_format = |relative: &Path| match &args.format {
        Some(ext) => relative.with_extension(ext),
        None => relative.to_owned(),
    };
    let mut seen = std::collections::HashSet::new();
    let mut jobs = Vec::with_capacity(files.len());
    for (input, relative, bytes) in files {
        let output = args.output.as_ref().map(|out| {
            if single {
                out.clone()
            } else {
                out.join(with_format(&relative))
            }
        });
        if let Some(output) = &output {
            if !seen.insert(output.clone()) {
                bail!(
                    "two inputs would both be written to {} (give them different names, or one folder each)",
                    output.display()
                );
            }
        }
        let report = args.report.as_ref().map(|report| {
            if single {
                report.clone()
            } else {
                let mut name = relative.clone().into_os_string();
                name.push(".html");
                report.join(name)
            }
        });
        jobs.push(Job {
            input,
            output,
            report,
            bytes,
        });
    }
    refuse_replacing_inputs(&jobs)?;
    Ok(jobs)
}

/// One error before any work when a batch's OUT or report folder is named like a file
/// (`-o all.glb`, `--report r.html`) and is not a folder already: a batch would make a
/// folder of that name, which is not what the name asks for.
fn refuse_file_names_for_folders(args: &Args, files: usize) -> Result<()> {
    let is_mesh = |path: &Path| rtmesh::io::Format::from_path(path).is_ok();
    let is_html = |path: &Path| {
        path.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("html"))
    };
    let options = [
        (
            &args.output,
            "-o",
            "give a folder; --format picks the batch's output format",
        ),
        (
            &args.report,
            "--report",
            "give a folder; it gets one report per file and index.html",
        ),
    ];
    for (path, option, hint) in options {
        let Some(path) = path.as_deref().filter(|p| !p.is_dir()) else {
            continue;
        };
        if is_mesh(path) || is_html(path) {
            bail!(
                "{option} {}: a batch is written to a folder that mirrors its inputs ({files} files \
                 here), and this names a file ({hint})",
                path.display()
            );
        }
    }
    Ok(())
}

/// One error before any work when an output would replace an input of this run: its
/// own, as with `optimize d -o d`, or another's (where two inputs would be written to
/// one file, that is said first).
fn refuse_replacing_inputs(jobs: &[Job]) -> Result<()> {
    let inputs: Vec<(PathBuf, &str)> = (jobs.iter())
        .filter_map(|job| Some((std::fs::canonicalize(&job.input).ok()?, job.input.as_str())))
        .collect();
    for job in jobs {
        let Some(output) = job
            .output
            .as_ref()
            .and_then(|o| std::fs::canonicalize(o).ok())
        else {
            continue;
        };
        if let Some((_, input)) = inputs.iter().find(|(path, _)| *path == output) {
            let what = if *input == job.input {
                "the input file, which the output would replace".to_owned()
            } else {
                format!(
                    "the input {input}, which the output of {} would replace",
                    job.input
                )
            };
            bail!(
                "{}: this is {what}: write the outputs to another folder",
                job.output.as_ref().expect("canonicalized").display(),
            );
        }
    }
    Ok(())
}

/// Every mesh file under `dir`, recursively (links not followed), except in the
/// folders `skip` (canonical paths).
fn walk(dir: &Path, skip: &[PathBuf], found: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let kind = entry.file_type()?;
        let path = entry.path();
        if kind.is_dir() {
            if !skip.is_empty() && skip.contains(&std::fs::canonicalize(&path)?) {
                continue;
            }
            walk(&path, skip, found)?;
        } else if kind.is_file()
            && path
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| MESH_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        {
            found.push(path);
        }
    }
    Ok(())
}

/// Run `jobs`: small files in parallel, large ones one at a time; one JSON line or text
/// line per file as it finishes, a summary table at the end, `index` (the reports'
/// index page) if asked. Fails if any file failed.
pub fn run_jobs(jobs: &[Job], settings: &Settings, index: Option<&Path>) -> Result<()> {
    let bar = steps_bar(jobs.len());
    let printed = Mutex::new(());
    let finish = |report: &FileReport| {
        let _lock = printed.lock().expect("printing does not panic");
        bar.0.suspend(|| {
            if let Some(error) = &report.error {
                eprintln!("error: {error}");
            }
            if settings.json {
                let line = match report.optimize {
                    Some(_) => serde_json::to_string(report).expect("reports are plain data"),
                    None => json_line(report),
                };
                println!("{line}");
            } else if jobs.len() == 1 {
                print_one(report);
            } else {
                print_line(report);
            }
        });
        bar.advance(1);
    };
    let (small, large): (Vec<usize>, Vec<usize>) =
        (0..jobs.len()).partition(|&i| settings.jobs != 1 && jobs[i].bytes < LARGE_FILE_BYTES);
    let mut results: Vec<Option<FileReport>> = (0..jobs.len()).map(|_| None).collect();
    let slots = Mutex::new(&mut results);
    let store = |i: usize, report: FileReport| {
        finish(&report);
        slots.lock().expect("storing does not panic")[i] = Some(report);
    };
    if small.len() > 1 {
        bar.message("optimizing small files, one per core");
        let run_small = || {
            small.par_iter().for_each(|&i| {
                let report =
                    rtmesh::trace::measure::with_threads(1, || run_job(&jobs[i], settings, &()));
                store(i, report);
            })
        };
        rtmesh::trace::measure::with_threads(settings.jobs, run_small);
    }
    let one_at_a_time: Vec<usize> = if small.len() > 1 {
        large
    } else {
        small.into_iter().chain(large).collect()
    };
    for i in one_at_a_time {
        bar.message(&format!("optimizing {}", jobs[i].input));
        let progress: &dyn Progress = if jobs.len() == 1 { &bar } else { &() };
        let report = run_job(&jobs[i], settings, progress);
        store(i, report);
    }
    bar.0.finish_and_clear();
    let results: Vec<FileReport> = results.into_iter().flatten().collect();
    if jobs.len() > 1 {
        let table = summary_table(&results);
        if settings.json {
            eprint!("{table}");
        } else {
            print!("{table}");
        }
    }
    if let Some(index) = index {
        write_index(index, &results)?;
        if !settings.json {
            println!("wrote {}", index.display());
        }
    }
    let failed = results.iter().filter(|r| !r.ok).count();
    if failed > 0 {
        bail!("{failed} of {} files failed", results.len());
    }
    Ok(())
}

/// Optimize one file; every failure becomes the report's `error`.
fn run_job(job: &Job, settings: &Settings, progress: &dyn Progress) -> FileReport {
    let clock = std::time::Instant::now();
    let mut report = FileReport {
        input: job.input.clone(),
        output: None,
        report: None,
        pairs_file: None,
        sequences_file: None,
        side_files: Vec::new(),
        not_held: Vec::new(),
        not_read: Vec::new(),
        ok: false,
        error: None,
        seconds: 0.0,
        optimize: None,
    };
    if let Err(error) = optimize_file(job, settings, progress, &mut report) {
        // Every message names the input file.
        let message = format!("{error:#}");
        report.error = Some(if message.contains(&job.input) {
            message
        } else {
            format!("{}: {message}", job.input)
        });
    } else {
        report.ok = true;
    }
    report.seconds = clock.elapsed().as_secs_f64();
    report
}

fn optimize_file(
    job: &Job,
    settings: &Settings,
    progress: &dyn Progress,
    report: &mut FileReport,
) -> Result<()> {
    let scene = load(&job.input)?;
    if let (Some(output), false) = (&job.output, settings.dry_run) {
        refuse_overwriting_input(&job.input, &scene, output)?;
    }
    let mut optimized = rtmesh::optimize::optimize_mapped(&scene, &settings.options, progress)
        .with_context(|| job.input.clone())?;
    if let Some(measure) = &settings.options.measure {
        optimized.report.production =
            production_check(&job.input, &scene, &optimized, &settings.options, measure)?;
    }
    if !settings.dry_run {
        if let Some(output) = &job.output {
            create_parent(output)?;
            let (copies, notes) = write_mesh(&job.input, &optimized.scene, output)?;
            report.side_files = copies.copied;
            report.side_files.extend(notes.written_beside);
            report.not_held = notes.not_held;
            report.not_read = notes.not_read;
            report.output = Some(output.clone());
            if settings.options.target == Target::Pairs {
                let mut name = output.clone().into_os_string();
                name.push(".pairs.json");
                let path = PathBuf::from(name);
                write_pairs(&optimized, &path)?;
                report.pairs_file = Some(path);
            }
            if matches!(settings.options.target, Target::Strips | Target::Clusters) {
                let mut name = output.clone().into_os_string();
                name.push(format!(".{}.json", settings.options.target));
                let path = PathBuf::from(name);
                write_sequences(&optimized, &path)?;
                report.sequences_file = Some(path);
            }
        }
    }
    if let Some(path) = &job.report {
        let view = settings
            .options
            .measure
            .as_ref()
            .map_or(rtmesh::trace::View::Iso, |m| m.view);
        let pictures = Pictures::render(&scene, &optimized, view, settings.picture_size);
        let header = Header {
            output: (report.output.as_ref()).map_or(String::new(), |o| o.display().to_string()),
            not_held: report.not_held.clone(),
            not_read: report.not_read.clone(),
            ..header(job)
        };
        let html = rtmesh::optimize::html::html(&optimized.report, &header, Some(&pictures));
        create_parent(path)?;
        std::fs::write(path, html).with_context(|| format!("writing {}", path.display()))?;
        report.report = Some(path.clone());
    }
    report.optimize = Some(optimized.report);
    Ok(())
}

/// Embree on the input's triangles and the output's quads, where this rtmesh has it.
#[cfg(feature = "embree")]
fn production_check(
    input: &str,
    scene: &rtmesh::Scene,
    optimized: &Optimized,
    options: &OptimizeOptions,
    measure: &MeasureOptions,
) -> Result<Vec<rtmesh::optimize::ProductionCheck>> {
    if options.target != Target::Pairs {
        return Ok(Vec::new());
    }
    let settings = rtmesh_lab::tables::quads::QuadSettings {
        kinds: vec![
            rtmesh::trace::RayKind::Primary,
            rtmesh::trace::RayKind::Diffuse,
        ],
        size: measure.size,
        thread_counts: vec![rayon::current_num_threads()],
        runs: measure.runs,
        builds: 1,
        optimize: options.clone(),
    };
    let rows = rtmesh_lab::tables::quads::embree_quads_of(input, scene, optimized, &settings)?;
    Ok(rows
        .into_iter()
        .map(|r| rtmesh::optimize::ProductionCheck {
            tracer: "Embree 3: triangles, then quads".to_owned(),
            workload: r.workload.to_owned(),
            rays: r.rays,
            mrays_before: r.triangles_mrays_per_s,
            mrays_after: r.quads_mrays_per_s,
            bvh_bytes_before: r.triangles_bvh_bytes,
            bvh_bytes_after: r.quads_bvh_bytes,
            build_seconds_before: r.triangles_build_seconds,
            build_seconds_after: r.quads_build_seconds,
            same_hits: r.same_hits,
        })
        .collect())
}

/// Without Embree built in, no production tracer to ask.
#[cfg(not(feature = "embree"))]
fn production_check(
    _: &str,
    _: &rtmesh::Scene,
    _: &Optimized,
    _: &OptimizeOptions,
    _: &MeasureOptions,
) -> Result<Vec<rtmesh::optimize::ProductionCheck>> {
    Ok(Vec::new())
}

fn create_parent(path: &Path) -> Result<()> {
    match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => std::fs::create_dir_all(parent)
            .with_context(|| format!("creating the folder {}", parent.display())),
        _ => Ok(()),
    }
}

/// The explicit pair list (HIPRT's `trianglePairIndices`): per primitive (geometry,
/// group and material, in the order the writers write them), the flat list of paired
/// triangle indices `a0, b0, a1, b1, …` counted within the primitive.
#[derive(Serialize)]
struct PairsFile {
    schema: u32,
    format: &'static str,
    primitives: Vec<PrimitivePairs>,
}

#[derive(Serialize)]
struct PrimitivePairs {
    geometry: usize,
    group: u32,
    material: u32,
    triangles: usize,
    #[serde(rename = "trianglePairIndices")]
    triangle_pair_indices: Vec<u32>,
}

fn write_pairs(optimized: &Optimized, path: &Path) -> Result<()> {
    let mut primitives = Vec::new();
    for (g, mesh) in optimized.scene.meshes.iter().enumerate() {
        let paired = 2 * optimized.pair_counts[g] as u32;
        for ((group, material), ids) in mesh.primitives() {
            let local_paired = ids.iter().filter(|&&t| t < paired).count() as u32;
            primitives.push(PrimitivePairs {
                geometry: g,
                group,
                material,
                triangles: ids.len(),
                triangle_pair_indices: (0..local_paired).collect(),
            });
        }
    }
    let file = PairsFile {
        schema: 1,
        format: "rtmesh pairs: triangles trianglePairIndices[2k] and [2k+1] of each primitive form a quad",
        primitives,
    };
    std::fs::write(path, serde_json::to_string(&file)?)
        .with_context(|| format!("writing {}", path.display()))
}

/// The strip or cluster table: per primitive (geometry, group and material, in the
/// order the writers write them), the lengths of the strips or clusters that lie back
/// to back in the primitive's triangle order.
#[derive(Serialize)]
struct SequencesFile {
    schema: u32,
    format: &'static str,
    target: Target,
    primitives: Vec<PrimitiveSequences>,
}

#[derive(Serialize)]
struct PrimitiveSequences {
    geometry: usize,
    group: u32,
    material: u32,
    triangles: usize,
    lengths: Vec<u32>,
}

fn write_sequences(optimized: &Optimized, path: &Path) -> Result<()> {
    let mut primitives = Vec::new();
    for (g, mesh) in optimized.scene.meshes.iter().enumerate() {
        // Each strip or cluster lies within one primitive: walk them in geometry order
        // and hand each to the primitive of its first triangle.
        let key = |t: usize| {
            (
                mesh.group_of(t),
                mesh.material_ids.get(t).copied().unwrap_or(0),
            )
        };
        let mut by_key: std::collections::BTreeMap<(u32, u32), Vec<u32>> = Default::default();
        let mut first = 0usize;
        for &length in &optimized.sequences[g] {
            by_key.entry(key(first)).or_default().push(length);
            first += length as usize;
        }
        for ((group, material), ids) in mesh.primitives() {
            primitives.push(PrimitiveSequences {
                geometry: g,
                group,
                material,
                triangles: ids.len(),
                lengths: by_key.remove(&(group, material)).unwrap_or_default(),
            });
        }
    }
    let file = SequencesFile {
        schema: 1,
        format: "rtmesh sequences: each primitive's triangles are strips (or clusters) of these lengths, back to back",
        target: optimized.report.target,
        primitives,
    };
    std::fs::write(path, serde_json::to_string(&file)?)
        .with_context(|| format!("writing {}", path.display()))
}

/// The report's header for `job`.
fn header(job: &Job) -> Header {
    use sha2::Digest;
    let input_sha256 = if job.input.starts_with("builtin:") {
        "built-in scene".to_owned()
    } else {
        std::fs::read(&job.input)
            .map(|bytes| format!("{:x}", sha2::Sha256::digest(bytes)))
            .unwrap_or_default()
    };
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| {
            info.lines().find_map(|l| {
                l.strip_prefix("model name")
                    .map(|v| v.trim_start_matches([' ', '\t', ':']).to_owned())
            })
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned());
    Header {
        command: std::env::args().collect::<Vec<_>>().join(" "),
        input: job.input.clone(),
        input_sha256,
        cpu,
        threads: rayon::current_num_threads(),
        date: humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
        ..Header::default()
    }
}

fn primary_of(
    report: &OptimizeReport,
) -> Option<(&rtmesh::optimize::Figures, &rtmesh::optimize::Figures)> {
    report.before.as_ref().zip(report.after.as_ref())
}

fn print_one(file: &FileReport) {
    let Some(r) = &file.optimize else {
        return;
    };
    println!(
        "{}: {} → {} triangles, {:.2}% paired ({}), prepared in {:.3} s",
        file.input,
        r.triangles_in,
        r.triangles_out,
        100.0 * r.pair_ratio,
        r.pairing
            .as_ref()
            .map_or("no pairing", |p| p.method.as_str()),
        r.step_seconds.prepare
    );
    let rep = &r.repairs;
    println!(
        "  repairs      {} vertices welded, {} degenerate and {} duplicate triangles removed, {} geometries split, {} merge groups, {} alpha splits",
        rep.merged_vertices, rep.removed_degenerate, rep.removed_duplicates, rep.split_geometries, rep.merged_groups, rep.split_alpha_geometries
    );
    if let Some(p) = &r.pairing {
        println!(
            "  first-fit    Embree {:.2}%, HIPRT 32 {:.2}%, GPURT 64 {:.2}%: {}",
            100.0 * p.first_fit.embree_window_32,
            100.0 * p.first_fit.wave_32,
            100.0 * p.first_fit.wave_64,
            if p.first_fit.exact {
                "exactly rtmesh's pairs"
            } else {
                "NOT exactly rtmesh's pairs"
            }
        );
    }
    if let Some((b, a)) = primary_of(r) {
        for (name, before, after) in [
            ("primary", &b.primary, &a.primary),
            ("diffuse", &b.diffuse, &a.diffuse),
            ("shadow", &b.shadow, &a.shadow),
        ] {
            println!(
                "  {name:<8}     box/ray {:.2} → {:.2}, tri/ray {:.2} → {:.2} (+{:.2} pair tests), Mrays/s {:.2} → {:.2} ({:+.1}%)",
                before.box_tests_per_ray,
                after.box_tests_per_ray,
                before.tri_tests_per_ray,
                after.tri_tests_per_ray,
                after.pair_tests_per_ray,
                before.mrays_per_s,
                after.mrays_per_s,
                100.0 * (after.mrays_per_s / before.mrays_per_s.max(1e-12) - 1.0)
            );
        }
        println!(
            "  bvh          {} → {} bytes, built in {:.4} → {:.4} s",
            b.bvh_bytes, a.bvh_bytes, b.build_seconds, a.build_seconds
        );
    }
    if let Some(same) = &r.same_hits {
        println!(
            "  same hits    {:.3}% of {} primary rays ({} ties at the same distance, {} different)",
            100.0 * same.share,
            same.rays,
            same.ties,
            same.different
        );
    }
    for (what, path) in [
        ("wrote", &file.output),
        ("wrote pairs", &file.pairs_file),
        ("wrote report", &file.report),
    ] {
        if let Some(path) = path {
            println!("{what} {}", path.display());
        }
    }
    if !file.side_files.is_empty() {
        println!(
            "copied {} files the output refers to beside it (material libraries, textures)",
            file.side_files.len()
        );
    }
}

fn print_line(file: &FileReport) {
    if let Some(r) = &file.optimize {
        println!(
            "ok    {}: {} → {} triangles, {:.2}% paired, {:.2} s",
            file.input,
            r.triangles_in,
            r.triangles_out,
            100.0 * r.pair_ratio,
            file.seconds
        );
    }
}

/// The table after a batch: per file, triangles, pair ratio, primary box/ray and Mrays/s
/// before → after, seconds.
fn summary_table(results: &[FileReport]) -> String {
    let mut out = format!(
        "\n{:<40} {:>9} {:>9} {:>7} {:>15} {:>17} {:>17} {:>8}\n",
        "file",
        "tris in",
        "tris out",
        "paired",
        "box/ray",
        "primary Mrays/s",
        "diffuse Mrays/s",
        "seconds"
    );
    let arrow = |b: f64, a: f64| format!("{b:.2} → {a:.2}");
    for file in results {
        let name = file.input.rsplit('/').next().unwrap_or(&file.input);
        let line = match &file.optimize {
            Some(r) => {
                let (boxes, primary, diffuse) = match primary_of(r) {
                    Some((b, a)) => (
                        arrow(b.primary.box_tests_per_ray, a.primary.box_tests_per_ray),
                        arrow(b.primary.mrays_per_s, a.primary.mrays_per_s),
                        arrow(b.diffuse.mrays_per_s, a.diffuse.mrays_per_s),
                    ),
                    None => ("—".into(), "—".into(), "—".into()),
                };
                format!(
                    "{name:<40} {:>9} {:>9} {:>6.2}% {boxes:>15} {primary:>17} {diffuse:>17} {:>8.2}",
                    r.triangles_in,
                    r.triangles_out,
                    100.0 * r.pair_ratio,
                    file.seconds
                )
            }
            None => format!(
                "{name:<40} failed: {}",
                file.error.as_deref().unwrap_or("failed")
            ),
        };
        out.push_str(&line);
        out.push('\n');
    }
    let failed = results.iter().filter(|r| !r.ok).count();
    out.push_str(&format!(
        "{} files, {} failed, {:.1} s of work\n",
        results.len(),
        failed,
        results.iter().map(|r| r.seconds).sum::<f64>()
    ));
    out
}

/// A plain page linking every report, with the summary table.
fn write_index(path: &Path, results: &[FileReport]) -> Result<()> {
    let mut html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><meta http-equiv=\"Content-Security-Policy\" content=\"{}\"><title>rtmesh optimize</title></head><body><h1>rtmesh optimize</h1><table>\n<tr><th>file</th><th>triangles</th><th>paired</th><th>primary box/ray</th><th>status</th></tr>\n",
        rtmesh::optimize::html::CONTENT_SECURITY_POLICY
    );
    let dir = path.parent().unwrap_or(Path::new("."));
    for file in results {
        let link = file
            .report
            .as_ref()
            .map(|r| r.strip_prefix(dir).unwrap_or(r).display().to_string());
        let name = match &link {
            Some(link) => format!("<a href=\"{link}\">{}</a>", file.input),
            None => file.input.clone(),
        };
        let row = match &file.optimize {
            Some(r) => format!(
                "<td>{} → {}</td><td>{:.2}%</td><td>{}</td><td>ok</td>",
                r.triangles_in,
                r.triangles_out,
                100.0 * r.pair_ratio,
                primary_of(r).map_or("—".to_owned(), |(b, a)| format!(
                    "{:.2} → {:.2}",
                    b.primary.box_tests_per_ray, a.primary.box_tests_per_ray
                ))
            ),
            None => format!(
                "<td></td><td></td><td></td><td>{}</td>",
                file.error.as_deref().unwrap_or("failed")
            ),
        };
        html.push_str(&format!("<tr><td>{name}</td>{row}</tr>\n"));
    }
    html.push_str("</table></body></html>\n");
    create_parent(path)?;
    std::fs::write(path, html).with_context(|| format!("writing {}", path.display()))
}

impl Job {
    /// A job for a built-in scene, written to `dir`.
    pub fn builtin(name: &str, dir: &Path) -> Self {
        Self {
            input: format!("builtin:{name}"),
            output: Some(dir.join(format!("{name}.glb"))),
            report: Some(dir.join(format!("{name}.html"))),
            bytes: 0,
        }
    }
}
