//! Solves with faer's supernodal Cholesky factor for `W` right sides at once (four or eight), each
//! unknown's `W` values side by side in registers.
//!
//! With `A = Pᵀ L Lᵀ P`, a supernode holds columns `c..c + k` of `L` as one dense column-major block
//! `[L_top; L_bot]` of `k + |R|` rows (`L_top` lower triangular `k × k`, `L_bot` the rows `R` below
//! it). Its columns are taken four at a time ([`BLOCK`]). The forward substitution `L y = P b`
//! visits the supernodes in order; for a block of columns `J` it solves their small triangle
//! (`y_j ← (y_j − Σ_(i∈J, i<j) L_ji y_i) / L_jj`), then subtracts `Σ_(j∈J) L_ij y_j` from every later
//! row `i` of the supernode and, through a buffer added to `y_R` when the supernode is done, from
//! the rows below. The backward substitution `Lᵀ x = y` visits the supernodes last first: `g = x_R`
//! is gathered once, and for the blocks from the last, `x_j ← (x_j − Σ_(i later) L_ij x_i −
//! L_bot,jᵀ g − Σ_(i∈J, i>j) L_ij x_i) / L_jj`, the four columns' sums over the rows taken in one
//! sweep as four independent sums.
//!
//! Every value of `L` is read once per substitution, in the order it is stored, and serves all `W`
//! right sides, an unknown loaded once serving the four columns of a block. faer's own solve hands
//! each block to a general matrix product, which first copies (packs) `L_bot`: a second pass over the
//! factor for a product only four columns wide. Where the CPU has AVX2 the multiply-adds are written
//! as vector instructions (otherwise the compiler vectorised the forward substitution across rows,
//! with a transposition of every four of them). Figures: `BENCHMARKS.md`, *Modal analysis: the
//! factor read once per solve*.
//!
//! A substitution covers a [`Part`]: a range of supernodes and their unknowns, so that the two
//! halves of a split tree ([`super::supernodal_split`]) can run apart. What the forward substitution
//! of a part takes from rows outside it is added to a vector of its own, and the backward one reads
//! those rows, solved, from another.
//!
//! The sums are taken in a fixed order that depends neither on `W` nor on the thread, so each
//! column's solution is the same to the bit however the columns are batched.

use std::ops::Range;

use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;

use super::isa::{Kernel, avx2};

/// `W` values of one unknown, one per right side.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(32))]
pub(super) struct Lanes<const W: usize>(pub(super) [f64; W]);

impl<const W: usize> Default for Lanes<W> {
    fn default() -> Self {
        Self([0.0; W])
    }
}

/// The kernel's one multiply-add, `a − v s` lane by lane, fused: written lane by lane for any CPU, or
/// as AVX2 instructions on whole registers (the compiler otherwise vectorised the forward
/// substitution across rows, with a transposition of every four of them). Both round once per lane,
/// so they agree to the bit.
trait Fused<const W: usize>: Copy {
    /// `a − v s`.
    fn minus_scaled(self, a: Lanes<W>, v: Lanes<W>, s: f64) -> Lanes<W>;
}

/// Lane by lane.
#[derive(Clone, Copy)]
struct Scalar;

impl<const W: usize> Fused<W> for Scalar {
    #[inline(always)]
    fn minus_scaled(self, a: Lanes<W>, v: Lanes<W>, s: f64) -> Lanes<W> {
        let mut out = a;
        for (o, &b) in out.0.iter_mut().zip(&v.0) {
            *o = (-b).mul_add(s, *o);
        }
        out
    }
}

#[cfg(target_arch = "x86_64")]
impl<const W: usize> Fused<W> for pulp::x86::V3 {
    #[inline(always)]
    fn minus_scaled(self, a: Lanes<W>, v: Lanes<W>, s: f64) -> Lanes<W> {
        let minus = self.splat_f64x4(-s);
        let mut out = a;
        for (o, b) in out.0.as_chunks_mut::<4>().0.iter_mut().zip(v.0.as_chunks::<4>().0) {
            *o = pulp::cast(self.mul_add_f64x4(minus, pulp::cast(*b), pulp::cast(*o)));
        }
        out
    }
}

impl<const W: usize> Lanes<W> {
    /// Each lane divided by `d`.
    #[inline(always)]
    fn over(self, d: f64) -> Self {
        Self(self.0.map(|a| a / d))
    }

    /// Lane-wise sum.
    #[inline(always)]
    pub(super) fn plus(self, v: Self) -> Self {
        let mut out = self;
        for (o, &b) in out.0.iter_mut().zip(&v.0) {
            *o += b;
        }
        out
    }
}

/// What one substitution covers: the supernodes `supernodes`, whose columns are the unknowns `x`
/// (the first being column `base`), and the rows from `outside` on, which are not in `x`.
pub(super) struct Part<'a, const W: usize> {
    /// The supernodes, in order.
    pub(super) supernodes: Range<usize>,
    /// The first unknown of `x`.
    pub(super) base: usize,
    /// The supernodes' unknowns, solved in place.
    pub(super) x: &'a mut [Lanes<W>],
    /// Rows from this one on are outside the part (the top of a split, or past the end); the rows
    /// below it that the part's patterns hold are all in `x`.
    pub(super) outside: usize,
}

/// The forward substitution `L y = b` over `part`: what its columns take from the rows outside it is
/// added to `taken` (indexed from `part.outside`).
pub(super) fn forward<const W: usize>(
    symbolic: &SymbolicSupernodalCholesky<usize>,
    values: &[f64],
    part: Part<'_, W>,
    taken: &mut [Lanes<W>],
) {
    run(Substitution { fused: Scalar, symbolic, values, part, rows_outside: Outside::Taken(taken) });
}

/// The backward substitution `Lᵀ x = y` over `part`, the rows outside it already solved (`solved`,
/// indexed from `part.outside`).
pub(super) fn backward<const W: usize>(
    symbolic: &SymbolicSupernodalCholesky<usize>,
    values: &[f64],
    part: Part<'_, W>,
    solved: &[Lanes<W>],
) {
    run(Substitution { fused: Scalar, symbolic, values, part, rows_outside: Outside::Solved(solved) });
}

/// Run `kernel` with AVX2's multiply-adds where the CPU has them and `W` fills whole registers.
fn run<const W: usize>(kernel: Substitution<'_, W, Scalar>) {
    #[cfg(target_arch = "x86_64")]
    if W.is_multiple_of(4)
        && let Some(simd) = pulp::x86::V3::try_new()
    {
        struct Run<'a, const W: usize>(Substitution<'a, W, pulp::x86::V3>);
        impl<const W: usize> pulp::WithSimd for Run<'_, W> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, _: S) {
                self.0.run()
            }
        }
        let Substitution { symbolic, values, part, rows_outside, .. } = kernel;
        return pulp::Simd::vectorize(simd, Run(Substitution { fused: simd, symbolic, values, part, rows_outside }));
    }
    avx2(kernel);
}

/// The rows outside a part: where the forward substitution adds to them, or the backward one reads
/// them.
enum Outside<'a, const W: usize> {
    Taken(&'a mut [Lanes<W>]),
    Solved(&'a [Lanes<W>]),
}

struct Substitution<'a, const W: usize, F> {
    fused: F,
    symbolic: &'a SymbolicSupernodalCholesky<usize>,
    values: &'a [f64],
    part: Part<'a, W>,
    rows_outside: Outside<'a, W>,
}

impl<const W: usize, F: Fused<W>> Kernel for Substitution<'_, W, F> {
    type Output = ();

    #[inline(always)]
    fn run(self) {
        let Self { fused, symbolic, values, part: Part { supernodes, base, x, outside }, rows_outside } = self;
        let node = |s: usize| Node {
            start: symbolic.supernode_begin()[s] - base,
            size: symbolic.supernode_end()[s] - symbolic.supernode_begin()[s],
            values: &values[symbolic.col_ptr_for_val()[s]..symbolic.col_ptr_for_val()[s + 1]],
        };
        let mut buffer = Vec::new();
        match rows_outside {
            Outside::Taken(taken) => {
                for s in supernodes {
                    let (node, rows) = (node(s), symbolic.supernode(s).pattern());
                    buffer.clear();
                    buffer.resize(rows.len(), Lanes::default());
                    for first in (0..node.size).step_by(BLOCK) {
                        match node.size - first {
                            1 => node.forward::<W, 1, F>(fused, first, x, &mut buffer),
                            2 => node.forward::<W, 2, F>(fused, first, x, &mut buffer),
                            3 => node.forward::<W, 3, F>(fused, first, x, &mut buffer),
                            _ => node.forward::<W, BLOCK, F>(fused, first, x, &mut buffer),
                        }
                    }
                    for (&r, t) in rows.iter().zip(&buffer) {
                        let row = if r < outside { &mut x[r - base] } else { &mut taken[r - outside] };
                        *row = row.plus(*t);
                    }
                }
            }
            Outside::Solved(solved) => {
                for s in supernodes.rev() {
                    let (node, rows) = (node(s), symbolic.supernode(s).pattern());
                    buffer.clear();
                    buffer.extend(rows.iter().map(|&r| if r < outside { x[r - base] } else { solved[r - outside] }));
                    for first in (0..node.size).step_by(BLOCK).rev() {
                        match node.size - first {
                            1 => node.backward::<W, 1, F>(fused, first, x, &buffer),
                            2 => node.backward::<W, 2, F>(fused, first, x, &buffer),
                            3 => node.backward::<W, 3, F>(fused, first, x, &buffer),
                            _ => node.backward::<W, BLOCK, F>(fused, first, x, &buffer),
                        }
                    }
                }
            }
        }
    }
}

/// Columns of a supernode taken together: each unknown loaded (and stored) once serves this many
/// values of `L`, in as many independent sums.
const BLOCK: usize = 4;

/// One supernode: its first column, its number of columns, its dense column-major block.
struct Node<'a> {
    start: usize,
    size: usize,
    values: &'a [f64],
}

impl Node<'_> {
    /// Column `j` of the block (its rows in the supernode, then the rows below).
    #[inline(always)]
    fn column(&self, j: usize) -> &[f64] {
        let rows = self.values.len() / self.size;
        &self.values[j * rows..(j + 1) * rows]
    }

    /// The forward substitution of columns `first..first + B`: their triangle, then what they take
    /// from the supernode's later rows (in `x`) and from the rows below (into `below`).
    #[inline(always)]
    fn forward<const W: usize, const B: usize, F: Fused<W>>(
        &self,
        f: F,
        first: usize,
        x: &mut [Lanes<W>],
        below: &mut [Lanes<W>],
    ) {
        let (start, size) = (self.start, self.size);
        for d in 0..B {
            let c = self.column(first + d);
            let xj = x[start + first + d].over(c[first + d]);
            x[start + first + d] = xj;
            for e in d + 1..B {
                x[start + first + e] = f.minus_scaled(x[start + first + e], xj, c[first + e]);
            }
        }
        let xs: [Lanes<W>; B] = std::array::from_fn(|d| x[start + first + d]);
        subtract(
            f,
            &mut x[start + first + B..start + size],
            std::array::from_fn(|d| &self.column(first + d)[first + B..size]),
            xs,
        );
        subtract(f, below, std::array::from_fn(|d| &self.column(first + d)[size..]), xs);
    }

    /// The backward substitution of columns `first..first + B`, the supernode's later rows (in `x`)
    /// and the rows below (`below`, gathered) already solved.
    #[inline(always)]
    fn backward<const W: usize, const B: usize, F: Fused<W>>(
        &self,
        f: F,
        first: usize,
        x: &mut [Lanes<W>],
        below: &[Lanes<W>],
    ) {
        let (start, size) = (self.start, self.size);
        let mut sums: [Lanes<W>; B] = std::array::from_fn(|d| x[start + first + d]);
        dot(
            f,
            &mut sums,
            std::array::from_fn(|d| &self.column(first + d)[first + B..size]),
            &x[start + first + B..start + size],
        );
        dot(f, &mut sums, std::array::from_fn(|d| &self.column(first + d)[size..]), below);
        for d in (0..B).rev() {
            let c = self.column(first + d);
            let mut v = sums[d];
            for e in d + 1..B {
                v = f.minus_scaled(v, x[start + first + e], c[first + e]);
            }
            x[start + first + d] = v.over(c[first + d]);
        }
    }
}

/// `targets[r] −= Σ_d columns[d][r] xs[d]`, the columns summed in order.
#[inline(always)]
fn subtract<const W: usize, const B: usize>(
    f: impl Fused<W>,
    targets: &mut [Lanes<W>],
    columns: [&[f64]; B],
    xs: [Lanes<W>; B],
) {
    let columns = columns.map(|c| &c[..targets.len()]);
    for (r, t) in targets.iter_mut().enumerate() {
        let mut v = *t;
        for d in 0..B {
            v = f.minus_scaled(v, xs[d], columns[d][r]);
        }
        *t = v;
    }
}

/// `sums[d] −= Σ_r columns[d][r] sources[r]`, one independent sum per column.
#[inline(always)]
fn dot<const W: usize, const B: usize>(
    f: impl Fused<W>,
    sums: &mut [Lanes<W>; B],
    columns: [&[f64]; B],
    sources: &[Lanes<W>],
) {
    let columns = columns.map(|c| &c[..sources.len()]);
    for (r, s) in sources.iter().enumerate() {
        for d in 0..B {
            sums[d] = f.minus_scaled(sums[d], *s, columns[d][r]);
        }
    }
}
