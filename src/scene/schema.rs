//! The typed form of a scene file (TOML). Unknown keys are refused by serde; value checks are in
//! [`Scene::validate`].

use serde::{Deserialize, Serialize};

use super::script::{Skeleton, Track};
use super::selection::Selection;

/// A complete scene: what to simulate, with which method, seen from where.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Short name shown in lists.
    pub name: String,
    /// One line saying what the scene shows.
    #[serde(default)]
    pub description: String,
    /// Where the simulated mesh comes from.
    pub mesh: MeshSource,
    /// Rigid placement applied to the mesh after it is made.
    #[serde(default)]
    pub placement: Placement,
    /// Physical parameters.
    #[serde(default)]
    pub material: Material,
    /// Fixed vertices.
    #[serde(default)]
    pub anchors: Vec<Selection>,
    /// Gravity acceleration, m/s².
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// Constant point forces on selected vertices.
    #[serde(default)]
    pub loads: Vec<Load>,
    /// Static or scripted rigid bodies the mesh collides with.
    #[serde(default)]
    pub colliders: Vec<Collider>,
    /// Constraint tracks: keyframed or joint-following targets on vertex selections.
    #[serde(default)]
    pub tracks: Vec<Track>,
    /// A skeleton whose joints tracks can follow (none by default).
    #[serde(default)]
    pub skeleton: Skeleton,
    /// Parts simulated each by its own method and settings (connected components of the mesh).
    #[serde(default)]
    pub parts: Vec<Part>,
    /// Wind on every method (calm by default).
    #[serde(default)]
    pub wind: WindSpec,
    /// Method and its numerical settings.
    pub solver: SolverSettings,
    /// Initial view.
    #[serde(default)]
    pub camera: CameraSpec,
}

fn default_gravity() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}

/// A procedural generator with its parameters, or an OBJ file: a table named after the generator,
/// e.g. `[mesh.grid]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum MeshSource {
    /// Regular grid in the y = 0 plane, centred on the origin: x ∈ ±`size[0]`/2, z ∈ ±`size[1]`/2.
    Grid {
        /// Extent along x and z, metres.
        size: [f64; 2],
        /// Number of cells along x and z.
        segments: [usize; 2],
    },
    /// Two strips meeting at a crease along x (a V cross-section).
    VBeam {
        /// Length along x, metres.
        length: f64,
        /// Developed width (both wings), metres.
        width: f64,
        /// Opening angle between the wings, degrees (180 is flat).
        angle_deg: f64,
        /// Cells along x and across (across must be even).
        segments: [usize; 2],
    },
    /// Irregular Delaunay-refined sheet in the y = 0 plane, centred on the origin.
    DelaunaySheet {
        /// Extent along x and z, metres.
        size: [f64; 2],
        /// Target edge length, metres.
        edge: f64,
    },
    /// Geodesic sphere: icosahedron subdivided `frequency` times per edge.
    Icosphere {
        /// Radius, metres.
        radius: f64,
        /// Subdivisions per icosahedron edge (1 = icosahedron).
        frequency: usize,
    },
    /// Latitude/longitude sphere.
    UvSphere {
        /// Radius, metres.
        radius: f64,
        /// Rings between the poles.
        rings: usize,
        /// Segments around.
        sectors: usize,
    },
    /// A closed organic shell (body, head, tail, legs) for timing at the paper's scale.
    Creature {
        /// Overall length, metres.
        length: f64,
        /// Geodesic frequency (36 gives 12,962 vertices).
        frequency: usize,
    },
    /// The dancer's shell parts: hat, tunic and two trouser legs (four components, in that order).
    Dancer {
        /// Height of the figure, metres.
        height: f64,
        /// Segments around each tube.
        around: usize,
    },
    /// A triangle mesh from an OBJ file (path relative to the scene file).
    Obj {
        /// The file.
        path: String,
    },
}

/// Scale, rotation (Euler XYZ, degrees) then translation applied to the generated mesh, and how many
/// shifted copies of it the scene holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Placement {
    /// Uniform scale.
    pub scale: f64,
    /// Rotation about x, then y, then z, degrees.
    pub rotate_deg: [f64; 3],
    /// Translation, metres.
    pub translate: [f64; 3],
    /// Copies of the placed mesh in one scene (separate connected components), each shifted by
    /// `copy_offset` from the previous one; vertex `i` of copy `k` is vertex `k n + i`.
    pub copies: usize,
    /// Shift between neighbouring copies, metres.
    pub copy_offset: [f64; 3],
}

impl Default for Placement {
    fn default() -> Self {
        Self { scale: 1.0, rotate_deg: [0.0; 3], translate: [0.0; 3], copies: 1, copy_offset: [0.0; 3] }
    }
}

/// Physical parameters. Each solver family reads the ones it needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Material {
    /// Surface density, kg/m².
    pub density: f64,
    /// Shell area (stretch) stiffness k_A, N/m.
    pub k_area: f64,
    /// Shell edge-length (shear) stiffness k_L, N/m.
    pub k_length: f64,
    /// Shell bending stiffness k_B, N·m.
    pub k_bend: f64,
    /// Cloth edge-spring (stretch) stiffness k_s, N/m per spring.
    pub k_s: f64,
    /// Cloth bending rigidity per unit width k_b, N·m: each buckling spring's flexural rigidity is
    /// `k_b` times the width of cloth it stands for.
    pub k_b: f64,
    /// Cloth buckling springs' linear branch near rest, c_b, N/m per spring.
    pub c_b: f64,
    /// Cloth spring damping k_d, N·s/m per spring.
    pub k_d: f64,
    /// Static friction coefficient between the mesh and colliders.
    pub mu_s: f64,
    /// Kinetic (sliding) friction coefficient between the mesh and colliders.
    pub mu_k: f64,
    /// Position-based cloth (`pbd`): stretch stiffness `k ∈ [0, 1]` per iteration set (Müller 2007).
    pub pbd_stretch: f64,
    /// Position-based cloth (`pbd`): bending stiffness `k ∈ [0, 1]`.
    pub pbd_bend: f64,
    /// `xpbd`: compliance of the edge-length constraints, m/N (absent: `1/k_s`, the cloth's springs).
    pub compliance_stretch: Option<f64>,
    /// `xpbd`: compliance of the bending constraints, 1/(N·m) per hinge (absent: from `k_b`, the
    /// energy `k_b (θ − θ̄)² |e|/h̄` of the discrete shell's hinge).
    pub compliance_bend: Option<f64>,
    /// `xpbd`: the fraction of its stretch stiffness an edge keeps in compression, in [0, 1] (1: the
    /// same both ways; 0: tension only, as the implicit cloth's stretch springs, whose compression
    /// its buckling springs take and soon give up).
    pub compression: f64,
    /// Balloon: the enclosed volume is held at `k_pressure` times the rest volume (a closed mesh only;
    /// absent: no volume constraint).
    pub k_pressure: Option<f64>,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            density: 0.5,
            k_area: 1.0e3,
            k_length: 1.0e3,
            k_bend: 1.0e-2,
            k_s: 200.0,
            k_b: 1.0e-6,
            c_b: 200.0,
            k_d: 2.0e-3,
            mu_s: 0.0,
            mu_k: 0.0,
            pbd_stretch: 1.0,
            pbd_bend: 0.1,
            compliance_stretch: None,
            compliance_bend: None,
            compression: 1.0,
            k_pressure: None,
        }
    }
}

/// A constant force applied to each selected vertex.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Load {
    /// Which vertices.
    pub select: Selection,
    /// Force on each of them, newtons.
    pub force: [f64; 3],
}

/// A rigid body the mesh collides with: `{ sphere = { center = [..], radius = .. } }`, `{ plane = {..} }`
/// or `{ mesh = { path = "body.obj" } }`, each with an optional scripted `motion`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum Collider {
    /// A ball.
    Sphere {
        /// Centre at t = 0, metres.
        center: [f64; 3],
        /// Radius, metres.
        radius: f64,
        /// How it moves (still if absent).
        #[serde(default)]
        motion: Motion,
        /// A mass (kg) makes it a dynamic body for the position-based methods: it falls, rolls and is
        /// pushed by the cloth (its `motion` is then its initial velocity and spin).
        #[serde(default)]
        mass: Option<f64>,
    },
    /// A box.
    Box {
        /// Centre at t = 0, metres.
        center: [f64; 3],
        /// Half of each side, metres.
        half_extents: [f64; 3],
        /// Rotation (Euler XYZ, degrees) at t = 0.
        #[serde(default)]
        rotate_deg: [f64; 3],
        /// How it moves (still if absent).
        #[serde(default)]
        motion: Motion,
        /// A mass (kg) makes it a dynamic body (see the sphere's).
        #[serde(default)]
        mass: Option<f64>,
    },
    /// An infinite plane; the mesh stays on the side the normal points to.
    Plane {
        /// A point on the plane at t = 0.
        point: [f64; 3],
        /// Outward normal (need not be unit length).
        normal: [f64; 3],
        /// How it moves (still if absent).
        #[serde(default)]
        motion: Motion,
    },
    /// A closed triangle mesh from an OBJ file (path relative to the scene file), solid inside.
    Mesh {
        /// The file.
        path: String,
        /// Uniform scale applied to the file's coordinates.
        #[serde(default = "one")]
        scale: f64,
        /// Where the file's origin is placed at t = 0, metres.
        #[serde(default)]
        translate: [f64; 3],
        /// How it moves (still if absent); spin is about the placed origin.
        #[serde(default)]
        motion: Motion,
    },
}

fn one() -> f64 {
    1.0
}

/// A scripted rigid motion: centre `c(t) = c₀ + velocity·t + amplitude·sin(2π·frequency·t)`, and a
/// constant `spin` (angular velocity, axis × rad/s) about the centre.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Motion {
    /// Constant velocity, m/s.
    pub velocity: [f64; 3],
    /// Oscillation amplitude, m.
    pub amplitude: [f64; 3],
    /// Oscillation frequency, Hz.
    pub frequency: f64,
    /// Angular velocity, rad/s.
    pub spin: [f64; 3],
}

/// Connected components of the mesh simulated by their own method and settings: every component
/// with a vertex in `select`; what a part does not set comes from `[solver]`. Vertices in no part
/// run with `[solver]` as one more part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Part {
    /// Picks the part's components.
    pub select: Selection,
    /// Method of this part.
    #[serde(default)]
    pub method: Option<String>,
    /// Mode count (modal methods).
    #[serde(default)]
    pub modes: Option<usize>,
    /// Fixed step, s.
    #[serde(default)]
    pub step: Option<f64>,
    /// Rayleigh mass damping α, 1/s.
    #[serde(default)]
    pub rayleigh_alpha: Option<f64>,
    /// Rayleigh stiffness damping β, s.
    #[serde(default)]
    pub rayleigh_beta: Option<f64>,
    /// Modal methods: relative compliance of drag constraints.
    #[serde(default)]
    pub constraint_damping: Option<f64>,
    /// `rds`: whether the static responses to body loads join the modes (1) or not (0).
    #[serde(default)]
    pub load_responses: Option<i64>,
    /// `rds`: modal-derivative directions kept.
    #[serde(default)]
    pub derivatives: Option<i64>,
    /// `rds`: cubature elements (0: every element).
    #[serde(default)]
    pub cubature: Option<i64>,
    /// Target relative displacement-field error of this part: the part gets the cheapest model that
    /// meets it (as `solver.accuracy` does for a scene; `method`, else `[solver]`'s, names the family
    /// to choose from).
    #[serde(default)]
    pub accuracy: Option<f64>,
}

impl Part {
    /// `[solver]` with this part's settings in place: the part's own accuracy target, else none if it
    /// names a method, else `[solver]`'s.
    pub fn settings(&self, solver: &SolverSettings) -> SolverSettings {
        let mut s = solver.clone();
        if let Some(m) = &self.method {
            s.method = m.clone();
            s.accuracy = None;
        }
        s.accuracy = self.accuracy.or(s.accuracy);
        s.modes = self.modes.unwrap_or(s.modes);
        s.step = self.step.or(s.step);
        s.rayleigh_alpha = self.rayleigh_alpha.unwrap_or(s.rayleigh_alpha);
        s.rayleigh_beta = self.rayleigh_beta.unwrap_or(s.rayleigh_beta);
        s.constraint_damping = self.constraint_damping.or(s.constraint_damping);
        s.load_responses = self.load_responses.or(s.load_responses);
        s.derivatives = self.derivatives.or(s.derivatives);
        s.cubature = self.cubature.or(s.cubature);
        s
    }
}

/// Which method runs the scene, and its numerical settings (method-specific ones are ignored by others).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverSettings {
    /// Registered method name (`shellwarp scenes` lists them). May be left out when `accuracy` is
    /// given; with `accuracy`, a cloth method selects the cloth family to choose from.
    #[serde(default)]
    pub method: String,
    /// Target relative displacement-field error: the program then chooses the cheapest method and
    /// setting that meets it (see `solver::auto`), instead of `method` and `modes`.
    #[serde(default)]
    pub accuracy: Option<f64>,
    /// Fixed time step in seconds; the method's default if absent.
    #[serde(default)]
    pub step: Option<f64>,
    /// Inner step of methods that subdivide their step (`ds`), seconds; automatic if absent.
    #[serde(default)]
    pub substep: Option<f64>,
    /// Number of vibration modes for modal methods.
    #[serde(default = "default_modes")]
    pub modes: usize,
    /// Rayleigh mass damping α, 1/s.
    #[serde(default)]
    pub rayleigh_alpha: f64,
    /// Rayleigh stiffness damping β, s.
    #[serde(default)]
    pub rayleigh_beta: f64,
    /// Iteration cap of the method's inner solve (Newton, PCG).
    #[serde(default = "default_iterations")]
    pub iterations: usize,
    /// Relative tolerance of the inner solve.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Contact margin for collisions with colliders, metres (the method's default if absent).
    #[serde(default)]
    pub margin: Option<f64>,
    /// Modal methods: relative compliance of drag constraints (damped least squares; the method's
    /// default 1e-2 if absent). Smaller follows drags and tracks more tightly.
    #[serde(default)]
    pub constraint_damping: Option<f64>,
    /// `rds`: 1 (or absent): the static responses to a uniform acceleration along each axis join the
    /// modes; 0: they do not. Signed so that a value outside 0–1 is refused by `rds`'s range.
    #[serde(default)]
    pub load_responses: Option<i64>,
    /// `rds`: modal-derivative directions kept beside the modes after mass-PCA pruning (absent: all
    /// pairs of the modes, at most four per mode). Signed so that a negative value is refused by
    /// `rds`'s range, naming its key, rather than by the parser.
    #[serde(default)]
    pub derivatives: Option<i64>,
    /// `rds`: the energy's optimised cubature, at most this many elements (absent or 0: every
    /// element, exact). Signed for the same reason as `derivatives`.
    #[serde(default)]
    pub cubature: Option<i64>,
    /// Position-based methods: Gauss–Seidel sweeps over the constraints per substep.
    #[serde(default = "default_sweeps")]
    pub sweeps: usize,
    /// Position-based methods: substeps per step (`xpbd`; `pbd` takes one).
    #[serde(default = "default_substeps")]
    pub substeps: usize,
    /// Position-based methods: keep the cloth from passing through itself.
    #[serde(default)]
    pub self_collision: bool,
    /// Position-based methods: the cloth's collision thickness, metres (absent: a tenth of the mean
    /// edge length).
    #[serde(default)]
    pub thickness: Option<f64>,
    /// Position-based methods: the least area each triangle keeps, as a fraction of its rest area
    /// (in `[0, 1)`; absent or 0: no such constraint). Keeps a membrane of edges from collapsing a
    /// triangle in its plane and turning it over.
    #[serde(default)]
    pub least_area: Option<f64>,
}

fn default_substeps() -> usize {
    10
}
fn default_sweeps() -> usize {
    2
}

/// A uniform wind with optional gusts (`[wind]`), acting on every method's triangles as aerodynamic
/// drag on the normal relative velocity (see `solver::wind`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WindSpec {
    /// Mean air velocity, m/s (zero: no wind).
    pub velocity: [f64; 3],
    /// Drag coefficient of the normal flow.
    pub drag: f64,
    /// Air density, kg/m³.
    pub air_density: f64,
    /// Relative gust amplitude (0: steady wind).
    pub gust: f64,
    /// Base frequency of the gusts, Hz.
    pub gust_frequency: f64,
    /// Seed of the gusts.
    pub seed: u64,
}

impl Default for WindSpec {
    fn default() -> Self {
        Self { velocity: [0.0; 3], drag: 1.0, air_density: 1.2, gust: 0.0, gust_frequency: 0.5, seed: 0 }
    }
}

fn default_modes() -> usize {
    8
}
fn default_iterations() -> usize {
    50
}
fn default_tolerance() -> f64 {
    1e-8
}

/// Where the camera starts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraSpec {
    /// Eye position, metres.
    pub eye: [f64; 3],
    /// Point looked at, metres.
    pub target: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
}

impl Default for CameraSpec {
    fn default() -> Self {
        Self { eye: [0.0, 1.0, 3.0], target: [0.0; 3], fov_deg: 45.0 }
    }
}
