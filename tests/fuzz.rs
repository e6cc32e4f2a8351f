//! Fuzzed inputs: the built-in scenes mutated at the byte and token level (numbers replaced by
//! hostile values, bytes changed, lines repeated or dropped) with hostile `--set` overrides; OBJ
//! files with hostile numbers and indices, degenerate, doubled and non-manifold faces, huge polygons
//! and thousands of unused vertices, run by every kind of method; and damaged mode-cache files
//! (truncated, bit-flipped, from another mesh, spliced, padded, random). A scene or OBJ case is parsed,
//! realised, built and stepped a few times in-process and must end in a clean error or in finite
//! positions — never a panic, a non-finite state reported as fine, or a hang (each case runs on its
//! own thread with a deadline); a cache case must load only the clean file, and then exactly. Cases
//! run under a 2 GB memory budget (`memory::limit_to`), so work a mutation makes huge is refused by
//! its estimate rather than run for minutes. The generator is a seeded xorshift, so a failing case is
//! named by its seed and replayed by it. A short run is in the suite; the long one is
//! `cargo test --release --test fuzz -- --ignored a_long` (`SHELLWARP_FUZZ_CASES`, default 100,000, from
//! seed `SHELLWARP_FUZZ_FIRST`, default 1,000,000), which prints every case as it runs and stops,
//! naming the case, if the process grows past a third of the machine's memory.

use std::io::Write;
use std::path::Path;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use shellwarp::energy::shell::ShellStiffness;
use shellwarp::scene::{self, BUILTIN, Origin, Setup};
use shellwarp::solver;
use shellwarp::solver::modal::cache::Cache;
use shellwarp::solver::modal::compute::{ModalAnalysis, ModalProblem, analyse};

/// xorshift64*: enough randomness to mutate text, and replayable from a seed.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a>(&mut self, items: &[&'a str]) -> &'a str {
        items[self.below(items.len())]
    }
}

const HOSTILE: [&str; 16] = [
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "-0.0",
    "1e300",
    "-1e300",
    "1e-300",
    "4294967296",
    "18446744073709551615",
    "1e9",
    "3",
    "0.5",
    "\"x\"",
    "[]",
];

/// Keys the overrides hit. `solver.accuracy` is not among them: the automatic choice runs its
/// candidates to rest, up to a minute on a cloth scene under a moving ball, which a deadline per case
/// would call a hang.
const KEYS: [&str; 13] = [
    "solver.modes",
    "solver.step",
    "solver.substeps",
    "solver.sweeps",
    "solver.iterations",
    "material.k_bend",
    "material.density",
    "material.k_s",
    "gravity",
    "mesh.grid.segments",
    "mesh.grid.size",
    "placement.scale",
    "solver.thickness",
];

/// The byte ranges of the numbers in `text`.
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_alphanumeric() && b[i - 1] != b'_') {
            let start = if i > 0 && b[i - 1] == b'-' { i - 1 } else { i };
            let mut j = i;
            while j < b.len() && (b[j].is_ascii_digit() || matches!(b[j], b'.' | b'e' | b'E' | b'-' | b'+')) {
                j += 1;
            }
            out.push((start, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// One to three mutations of `text`.
fn mutate(text: &str, rng: &mut Rng) -> String {
    let mut t = text.to_string();
    for _ in 0..1 + rng.below(3) {
        match rng.below(5) {
            0 | 1 => {
                let spans = numbers(&t);
                if let Some(&(a, b)) = spans.get(rng.below(spans.len())) {
                    let value = rng.pick(&HOSTILE);
                    t.replace_range(a..b, value);
                }
            }
            2 => {
                // A byte changed to a printable one (the text stays UTF-8: only ASCII bytes are hit).
                let at = rng.below(t.len());
                if t.is_char_boundary(at) && t.as_bytes()[at].is_ascii() && t.is_char_boundary(at + 1) {
                    const BYTES: &[u8] = b" =[]{}\",.#0123456789-eaxz\n";
                    let c = BYTES[rng.below(BYTES.len())] as char;
                    t.replace_range(at..at + 1, &c.to_string());
                }
            }
            3 => {
                let lines: Vec<&str> = t.lines().collect();
                let k = rng.below(lines.len());
                let mut v: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
                v.insert(k, lines.get(k).copied().unwrap_or("").to_string());
                t = v.join("\n");
            }
            _ => {
                let mut v: Vec<&str> = t.lines().collect();
                if !v.is_empty() {
                    v.remove(rng.below(v.len()));
                }
                t = v.join("\n");
            }
        }
    }
    t
}

/// What one case came to.
#[derive(Debug, PartialEq)]
enum Outcome {
    /// Stepped with finite positions.
    Ran,
    /// A clean error somewhere along the way.
    Refused,
    /// A panic, with its message.
    Panicked(String),
    /// Positions went non-finite without an error.
    NonFinite,
    /// A damaged mode-cache file was trusted, with what came back.
    Trusted(String),
    /// Past the deadline.
    Hung,
}

/// Case `seed`: the built-in scene it mutates, the mutated text and the overrides.
fn case(seed: u64) -> (&'static str, String, Vec<String>) {
    let mut rng = Rng::new(seed);
    let (name, text) = BUILTIN[rng.below(BUILTIN.len())];
    let text = mutate(text, &mut rng);
    let mut overrides = Vec::new();
    for _ in 0..rng.below(3) {
        if rng.below(2) == 0 {
            overrides.push(format!("{}={}", rng.pick(&KEYS), rng.pick(&HOSTILE)));
        }
    }
    (name, text, overrides)
}

/// What case `seed` fuzzes: seven in ten a scene, two an OBJ file, one a mode-cache file.
fn run_case(seed: u64) -> Outcome {
    match seed % 10 {
        0..=6 => {
            let (name, text, overrides) = case(seed);
            let origin = Origin { label: format!("fuzz/{name}-{seed}.toml"), dir: env!("CARGO_MANIFEST_DIR").into() };
            run_scene(&text, origin, &overrides)
        }
        7 | 8 => run_obj_case(seed),
        _ => run_cache_case(seed),
    }
}

/// Parse, realise, build and step a scene.
fn run_scene(text: &str, origin: Origin, overrides: &[String]) -> Outcome {
    let Ok(parsed) = scene::parse(text, &origin, overrides) else { return Outcome::Refused };
    let Ok(setup) = Setup::new(parsed, origin) else { return Outcome::Refused };
    let Ok(mut s) = solver::build(&setup) else { return Outcome::Refused };
    for _ in 0..3 {
        if s.step().is_err() {
            return Outcome::Refused;
        }
    }
    if s.positions().iter().all(|p| p.is_finite()) { Outcome::Ran } else { Outcome::NonFinite }
}

/// The campaign's scratch folder (OBJ files and caches of its cases).
fn scratch() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| tempfile::Builder::new().prefix("shellwarp-fuzz-").tempdir().unwrap()).path()
}

/// A valid OBJ sheet of `nx × ny` quads split into triangles.
fn grid_obj(nx: usize, ny: usize) -> String {
    let mut t = String::new();
    for j in 0..=ny {
        for i in 0..=nx {
            t += &format!("v {} {} 0\n", i as f64 / nx as f64 - 0.5, j as f64 / ny as f64);
        }
    }
    let at = |i: usize, j: usize| j * (nx + 1) + i + 1;
    for j in 0..ny {
        for i in 0..nx {
            t += &format!(
                "f {} {} {}\nf {} {} {}\n",
                at(i, j),
                at(i + 1, j),
                at(i + 1, j + 1),
                at(i, j),
                at(i + 1, j + 1),
                at(i, j + 1)
            );
        }
    }
    t
}

/// Case `seed` as an OBJ file: its text and the method that runs it.
fn obj_case(seed: u64) -> (String, &'static str) {
    let mut rng = Rng::new(seed);
    let (nx, ny) = (1 + rng.below(6), 1 + rng.below(6));
    let mut t = grid_obj(nx, ny);
    let vertices = (nx + 1) * (ny + 1);
    for _ in 0..rng.below(4) {
        match rng.below(7) {
            0 => {
                // A face index made hostile.
                const BAD: [&str; 8] =
                    ["0", "-1", "-100000", "4294967296", "18446744073709551616", "1/2/3", "x", "99999999"];
                let faces: Vec<usize> = t.match_indices("\nf ").map(|(i, _)| i + 3).collect();
                if let Some(&at) = faces.get(rng.below(faces.len())) {
                    let end = at + t[at..].find(' ').unwrap_or(0);
                    t.replace_range(at..end, rng.pick(&BAD));
                }
            }
            1 => t += &format!("f 1 1 {}\n", 1 + rng.below(vertices)), // degenerate
            2 => t += "f 1 2 3\nf 2 1 3\nf 1 2 4\n",                   // doubled, non-manifold
            3 => {
                // A polygon of many corners, some repeated.
                let n = 3 + rng.below(20_000);
                t += &format!("f {}\n", (0..n).map(|k| (1 + k % vertices).to_string()).collect::<Vec<_>>().join(" "));
            }
            4 => t += &"v 0 0 0\n".repeat(rng.below(100_000)), // many unreferenced vertices
            5 => t = t.replacen("v ", &format!("v {} ", rng.pick(&HOSTILE)), 1),
            _ => t = mutate(&t, &mut rng),
        }
    }
    const METHODS: [&str; 8] = ["rigid", "xpbd", "pbd", "cloth", "lma", "mwts", "mwts-rs", "ds-implicit"];
    (t, METHODS[rng.below(METHODS.len())])
}

/// Load case `seed`'s OBJ file as a scene's mesh (anchored along one side) and step it.
fn run_obj_case(seed: u64) -> Outcome {
    let (obj, method) = obj_case(seed);
    let file = format!("obj-{seed}.obj");
    std::fs::write(scratch().join(&file), obj).unwrap();
    let text = format!(
        "name = \"fuzz-obj\"\n[mesh.obj]\npath = \"{file}\"\n[[anchors]]\nbox = {{ min = [-1.0, -1.0, -1.0], max = [-0.45, 2.0, 1.0] }}\n[solver]\nmethod = \"{method}\"\n"
    );
    let outcome =
        run_scene(&text, Origin { label: format!("fuzz/obj-{seed}.toml"), dir: scratch().to_path_buf() }, &[]);
    let _ = std::fs::remove_file(scratch().join(&file));
    outcome
}

/// A small anchored strip's modal problem; `segments` makes a different mesh.
struct Strip {
    mesh: shellwarp::mesh::TriMesh,
    masses: Vec<f64>,
}

impl Strip {
    fn new(segments: usize) -> Self {
        let mesh = shellwarp::mesh::generate::grid([0.4, 0.1], [segments, 2]).unwrap();
        let masses = mesh.vertex_areas().iter().map(|a| 0.5 * a).collect();
        Self { mesh, masses }
    }
    fn problem(&self) -> ModalProblem<'_> {
        let stiffness = ShellStiffness { k_area: 10.0, k_length: 10.0, k_bend: 0.05 };
        ModalProblem {
            mesh: &self.mesh,
            anchors: &[0, 1, 2, 3, 4, 5],
            masses: &self.masses,
            stiffness,
            modes: 3,
            keep_rigid: false,
        }
    }
}

/// The two strips, the first's analysis, and both cache files' bytes, made once.
fn cache_fixture() -> &'static (Strip, ModalAnalysis, Vec<u8>, Vec<u8>) {
    static FIXTURE: OnceLock<(Strip, ModalAnalysis, Vec<u8>, Vec<u8>)> = OnceLock::new();
    FIXTURE.get_or_init(|| {
        let cache = Cache::at(scratch().join("clean"));
        let bytes = |strip: &Strip| {
            let analysis = analyse(&strip.problem(), &|_| {}).unwrap();
            cache.store(&strip.problem(), &analysis);
            (analysis, std::fs::read(cache.path(&strip.problem()).unwrap()).unwrap())
        };
        let (a, b) = (Strip::new(8), Strip::new(10));
        let ((analysis, a_bytes), (_, b_bytes)) = (bytes(&a), bytes(&b));
        (a, analysis, a_bytes, b_bytes)
    })
}

/// Case `seed` as a damaged cache file: the first strip's entry truncated, bit-flipped, replaced by
/// the other mesh's, spliced, padded or random. It must load only if it is the clean file, and then
/// exactly.
fn run_cache_case(seed: u64) -> Outcome {
    let (strip, clean, good, other) = cache_fixture();
    let mut rng = Rng::new(seed);
    let mut bytes = good.clone();
    match rng.below(6) {
        0 => bytes.truncate(rng.below(good.len() + 1)),
        1 => {
            for _ in 0..1 + rng.below(8) {
                let at = rng.below(bytes.len());
                bytes[at] ^= 1 << rng.below(8);
            }
        }
        2 => bytes = other.clone(),
        3 => bytes = [&good[..rng.below(good.len())], &other[rng.below(other.len())..]].concat(),
        4 => bytes.extend((0..1 + rng.below(64)).map(|_| rng.next() as u8)),
        _ => bytes = (0..rng.below(2 * good.len())).map(|_| rng.next() as u8).collect(),
    }
    let cache = Cache::at(scratch().join(format!("cache-{seed}")));
    let path = cache.path(&strip.problem()).unwrap();
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, &bytes).unwrap();
    let loaded = cache.load(&strip.problem());
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
    match (loaded, bytes == *good) {
        (None, false) => Outcome::Refused,
        (Some(a), true) if a == *clean => Outcome::Ran,
        (got, _) => Outcome::Trusted(format!("{} bytes loaded as {:?}", bytes.len(), got.map(|a| a.residuals))),
    }
}

/// Case `seed` on its own thread, given `deadline`.
fn guarded(seed: u64, deadline: Duration) -> Outcome {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let outcome = std::panic::catch_unwind(|| run_case(seed)).unwrap_or_else(|p| {
            let what = p.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| p.downcast_ref::<String>().cloned());
            Outcome::Panicked(what.unwrap_or_default())
        });
        let _ = tx.send(outcome);
    });
    rx.recv_timeout(deadline).unwrap_or(Outcome::Hung)
}

/// The case running now, for the memory watchdog.
static CURRENT: AtomicU64 = AtomicU64::new(u64::MAX);

/// A thread that ends the process, naming the case, once resident memory passes `limit` bytes: a
/// case that grows without being refused would otherwise be killed by the kernel, seed unknown.
fn watch_memory(limit: u64) {
    std::thread::spawn(move || {
        loop {
            std::thread::sleep(Duration::from_millis(20));
            let rss = shellwarp::memory::resident_bytes();
            if rss > limit {
                eprintln!("case {} grew the process to {:.2} GB", CURRENT.load(Ordering::SeqCst), rss as f64 / 1e9);
                std::process::exit(3);
            }
        }
    });
}

/// Run `cases` seeds from `first`; the failures by seed, and the counts. With `log`, each case's seed
/// and outcome are printed as it runs (a long run's progress, and the culprit if it dies).
fn campaign(first: u64, cases: u64, log: bool) -> (Vec<(u64, Outcome)>, [usize; 2], Duration) {
    std::panic::set_hook(Box::new(|_| {})); // panics are counted, not printed
    shellwarp::memory::limit_to(2_000_000_000);
    watch_memory(MEMORY_LIMIT);
    let start = Instant::now();
    let mut bad = Vec::new();
    let mut counts = [0; 2];
    for seed in first..first + cases {
        CURRENT.store(seed, Ordering::SeqCst);
        let t = Instant::now();
        let outcome = guarded(seed, Duration::from_secs(30));
        if log {
            let mut err = std::io::stderr().lock();
            let _ = writeln!(
                err,
                "{seed} {outcome:?} {:.0} ms {:.0} MB",
                t.elapsed().as_secs_f64() * 1e3,
                shellwarp::memory::resident_bytes() as f64 / 1e6
            );
        }
        match outcome {
            Outcome::Ran => counts[0] += 1,
            Outcome::Refused => counts[1] += 1,
            other => bad.push((seed, other)),
        }
    }
    let _ = std::panic::take_hook();
    (bad, counts, start.elapsed())
}

/// One fuzz test at a time: each is CPU-bound on a 2-core machine, and the cases' time bounds
/// assume a core to themselves.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Hold the machine for one fuzz test (a failed test's poison is ignored).
fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// Resident memory past which a campaign stops and names its case: a third of this machine's 24 GB.
const MEMORY_LIMIT: u64 = 8_000_000_000;

#[test]
fn mutated_scenes_end_in_a_clean_error_or_finite_steps() {
    let _machine = serial();
    let (bad, [ran, refused], took) = campaign(0, 2000, false);
    eprintln!("2000 cases in {took:.1?}: {ran} ran, {refused} refused, {} bad", bad.len());
    assert!(bad.is_empty(), "{bad:?}");
    assert!(ran > 10 && refused > 10, "the mutations reach both outcomes ({ran} ran, {refused} refused)");
}

/// The cases the long runs caught, each now refused up front: a creature generated at ten times its
/// frequency (1.3 million vertices, grew the process past 8 GB), a creature a 1e9 bending stiffness
/// makes impossible to analyse (its eigen solve crawled for 50 s before failing), and a pile whose
/// strip starts half in the ground (6 s a step, crumpled).
#[test]
fn the_cases_the_long_runs_caught_are_refused_in_time() {
    let _machine = serial();
    shellwarp::memory::limit_to(2_000_000_000);
    for seed in [1_070_544, 1_004_464, 1_050_834] {
        let start = Instant::now();
        assert_eq!(guarded(seed, Duration::from_secs(30)), Outcome::Refused, "case {seed}");
        assert!(start.elapsed() < Duration::from_secs(15), "case {seed} took {:.1?}", start.elapsed());
    }
}

#[test]
#[ignore]
fn a_long_fuzz_run() {
    let _machine = serial();
    let cases = std::env::var("SHELLWARP_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(100_000);
    let first = std::env::var("SHELLWARP_FUZZ_FIRST").ok().and_then(|v| v.parse().ok()).unwrap_or(1_000_000);
    let (bad, [ran, refused], took) = campaign(first, cases, true);
    eprintln!("{cases} cases in {took:.1?}: {ran} ran, {refused} refused, {} bad: {bad:?}", bad.len());
    assert!(bad.is_empty());
}

/// Print case `SHELLWARP_FUZZ_SEED` (its scene, overrides and text) and run it: a failure's replay.
#[test]
#[ignore]
fn replay_one_case() {
    let seed = std::env::var("SHELLWARP_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(0);
    let (name, text, overrides) = case(seed);
    match seed % 10 {
        0..=6 => eprintln!("seed {seed}: {name} with {overrides:?}\n{text}"),
        7 | 8 => eprintln!("seed {seed}: OBJ run by {}\n{}", obj_case(seed).1, obj_case(seed).0),
        _ => eprintln!("seed {seed}: a damaged cache file"),
    }
    eprintln!("{:?}", guarded(seed, Duration::from_secs(30)));
}
