//! The contact law over blocks of consecutive pairs, structure of arrays and
//! branch-free.
//!
//! A per-contact loop is bound by latency: each contact is one dependent chain of
//! square roots and divisions. Here the pair list keeps its per-pair state in
//! [`PairBlock`]s of [`BLOCK`] consecutive pairs, one array per component. The pair
//! pass writes the geometry and relative velocity of [`LANES`] pairs of a block at a
//! time into a [`Geometry`] scratch, then [`law_block`] runs the same Hertz-Mindlin law
//! as [`hertz_mindlin_coefs`](super::hertz_mindlin_coefs) over those lanes with
//! selects instead of branches: pairs apart (overlap <= 0) are masked to zero rather
//! than compacted out. The compiler vectorises the loops, the chains of different
//! pairs overlap, and the results land in the pairs' own lanes with no scatter.

use crate::dynamics::PairParams;
use crate::math::Real;

/// The material's share of the law coefficients; a pair's own share is two numbers,
/// sqrt(R*) and sqrt(m* sqrt(R*)), so that the pair list stores 16 bytes of constants
/// per pair instead of 32 (see [`PairFactors`]).
///
/// For a pair: k_n = kn sqrt(R*) sqrt(d), c_n = cn sqrt(m* sqrt(R*)) d^{1/4}, and the
/// same with kt and ct, which equals [`LawCoefs`](super::LawCoefs) term by term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LawConsts {
    /// 2 E* (Pa).
    pub kn: Real,
    /// 2 xi sqrt(2 E*) (Pa^{1/2}).
    pub cn: Real,
    /// 8 G* (Pa).
    pub kt: Real,
    /// 2 xi sqrt(8 G*) (Pa^{1/2}).
    pub ct: Real,
    /// Friction coefficient mu (-).
    pub mu: Real,
    /// The linear law: then `kn` and `kt` are the springs k_n, k_t (N/m), `cn` and `ct`
    /// 2 xi sqrt(k_n) and 2 xi sqrt(k_t), and a pair's factors are 1 and sqrt(m*)
    /// ([`PairFactors::linear`]).
    pub linear: bool,
}

impl LawConsts {
    /// From the effective moduli E*, G* (Pa), damping ratio xi and friction mu.
    pub fn new(e_star: Real, g_star: Real, damping: Real, friction: Real) -> Self {
        LawConsts {
            kn: 2.0 * e_star,
            cn: 2.0 * damping * (2.0 * e_star).sqrt(),
            kt: 8.0 * g_star,
            ct: 2.0 * damping * (8.0 * g_star).sqrt(),
            mu: friction,
            linear: false,
        }
    }

    /// The linear law's: springs k_n, k_t (N/m), damping ratio xi, friction mu.
    pub fn linear(kn: Real, kt: Real, damping: Real, friction: Real) -> Self {
        LawConsts {
            kn,
            cn: 2.0 * damping * kn.sqrt(),
            kt,
            ct: 2.0 * damping * kt.sqrt(),
            mu: friction,
            linear: true,
        }
    }
}

/// A pair's share of the law coefficients (see [`LawConsts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairFactors {
    /// sqrt(R*) (m^{1/2}).
    pub sr: Real,
    /// sqrt(m* sqrt(R*)) (kg^{1/2} m^{1/4}).
    pub sm: Real,
}

impl PairFactors {
    /// From the effective radius R* (m) and mass m* (kg) of `p`.
    #[inline]
    pub fn new(p: &PairParams) -> Self {
        let sr = p.r_eff.sqrt();
        PairFactors {
            sr,
            sm: (p.m_eff * sr).sqrt(),
        }
    }

    /// The linear law's factors: 1 and sqrt(m*), so that the shared tangential pass
    /// gives k_t and 2 xi sqrt(m* k_t) unchanged.
    #[inline]
    pub fn linear(p: &PairParams) -> Self {
        PairFactors {
            sr: 1.0,
            sm: p.m_eff.sqrt(),
        }
    }
}

/// Pairs per block. A power of two: a pair index k lives in block `k >> BLOCK_SHIFT`,
/// lane `k & (BLOCK - 1)`.
///
/// The blocks are the pair state's layout in memory: each column of a block is one run
/// of `BLOCK` values (16 KiB, in a row of [`BLOCK_ROW`]), which the caches' prefetchers
/// follow as a stream. The law runs on [`LANES`] of them at a time, so that its scratch
/// and the lanes it reads stay in the first-level cache, and the step's pair pass
/// splits the blocks between threads in runs of 256 pairs. Measured on the settled pack of example 4.3 on one core
/// (`studies/step_roofline/pair_block_width/`): blocks of 2 048 pairs cost 7-11 % less
/// a particle-step than blocks of 128 from 80 568 to 1 083 192 spheres, and the same at
/// 8 952; whole packs take the same time. No result depends on the width: every width
/// from 128 to 4 096 gives the same bits.
///
/// The library's unit tests store blocks of 256 pairs, so that their small scenes span
/// many blocks, several runs a block and the sweep's pieces.
pub const BLOCK: usize = if cfg!(test) { 256 } else { 2048 };
/// log2 of [`BLOCK`].
pub const BLOCK_SHIFT: u32 = BLOCK.trailing_zeros();
/// Pairs the law runs on at a time: the width of the [`Geometry`] scratch. A power of
/// two that divides [`BLOCK`]; 128 keeps the scratch (15 KiB in 3D) and the lanes of
/// the block it writes (12 KiB) within a 32 KiB first-level cache.
pub const LANES: usize = 128;
const _: () = assert!(BLOCK.is_power_of_two() && LANES.is_power_of_two() && LANES <= BLOCK);
/// Length of a row (a column's run of lanes) of a [`PairBlock`] or [`RollBlock`]:
/// [`BLOCK`] lanes and one spare cache line (8 f64), never read or written.
///
/// Why the spare line: a first-level data cache of 32 KiB and 8 ways maps addresses
/// 4 KiB apart to the same set. Rows of exactly `BLOCK` f64 (16 KiB) put lane l of all
/// twelve rows of a 3D block (nine in 2D) in one set, more lines than its ways, so the
/// law and the gather evicted the lines they were about to use. One line more a row
/// puts them in consecutive sets. Measured on the settled 4.3 pack (8 952 spheres, one
/// core of an AMD EPYC of family 25 model 17): the law 0.65 of the unpadded one's time,
/// the step 0.82-0.88, the same bits (`studies/column_padding/`).
pub const BLOCK_ROW: usize = BLOCK + 8;
/// Length of a row of the [`Geometry`] scratch: [`LANES`] and one spare cache line, for
/// the reason given at [`BLOCK_ROW`] (rows of 1 KiB put every fourth row in one set).
pub const LANES_ROW: usize = LANES + 8;
// whole cache lines a row, so that every row of an aligned block starts on a line
const _: () = assert!(BLOCK_ROW.is_multiple_of(8) && LANES_ROW.is_multiple_of(8));

/// One pair's state, as [`PairBlock`] stores it lane by lane (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairRecord<const D: usize> {
    /// Tangential spring stretch (m).
    pub h: [Real; D],
    /// Total contact force on j (N).
    pub f: [Real; D],
    /// n x f_t (N), whose product with -(r_q - d/2) is the tangential force's
    /// torque on either end q; in 2D only the first component (out of plane) is used.
    pub t: [Real; D],
    /// Overlap (m), 0 when apart.
    pub d: Real,
    /// The pair's law factors (see [`PairFactors`]).
    pub coefs: PairFactors,
}

impl<const D: usize> Default for PairRecord<D> {
    fn default() -> Self {
        PairRecord {
            h: [0.0; D],
            f: [0.0; D],
            t: [0.0; D],
            d: 0.0,
            coefs: PairFactors::default(),
        }
    }
}

/// The state of [`BLOCK`] consecutive pairs of the list, one array per component, so
/// that [`law_block`] reads and writes whole vectors of lanes. Lanes past the end of
/// the list stay zero. Everything but the factors is zero for a pair apart.
///
/// Each row starts on a cache line (the block is aligned to 64 bytes and a row is a
/// whole number of lines), so that no vector of 8 lanes straddles two lines.
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub struct PairBlock<const D: usize> {
    /// Tangential spring stretch (m), by component.
    pub h: [[Real; BLOCK_ROW]; D],
    /// Total contact force on j (N), by component; the force on i is its opposite.
    pub f: [[Real; BLOCK_ROW]; D],
    /// n x f_t (N), by component: three in 3D; in 2D the first holds the
    /// out-of-plane one and the second stays zero. Zero unless the law runs with
    /// torques. The tangential force's torque on end q is -(r_q - d/2) n x f_t: the
    /// gather forms it from its own radius and `d`, which costs three products per
    /// pair end and saves storing both ends' torques (24 bytes per pair in 3D).
    pub t: [[Real; BLOCK_ROW]; D],
    /// Overlap d (m), 0 when apart.
    pub d: [Real; BLOCK_ROW],
    /// sqrt(R*) (see [`PairFactors`]).
    pub sr: [Real; BLOCK_ROW],
    /// sqrt(m* sqrt(R*)).
    pub sm: [Real; BLOCK_ROW],
}

impl<const D: usize> Default for PairBlock<D> {
    fn default() -> Self {
        PairBlock {
            h: [[0.0; BLOCK_ROW]; D],
            f: [[0.0; BLOCK_ROW]; D],
            t: [[0.0; BLOCK_ROW]; D],
            d: [0.0; BLOCK_ROW],
            sr: [0.0; BLOCK_ROW],
            sm: [0.0; BLOCK_ROW],
        }
    }
}

impl<const D: usize> PairBlock<D> {
    /// The state of lane `l` (`l < BLOCK`).
    #[inline]
    pub fn get(&self, l: usize) -> PairRecord<D> {
        PairRecord {
            h: std::array::from_fn(|a| self.h[a][l]),
            f: std::array::from_fn(|a| self.f[a][l]),
            t: std::array::from_fn(|a| self.t[a][l]),
            d: self.d[l],
            coefs: PairFactors {
                sr: self.sr[l],
                sm: self.sm[l],
            },
        }
    }

    /// Sets the state of lane `l` (`l < BLOCK`).
    #[inline]
    pub fn set(&mut self, l: usize, r: &PairRecord<D>) {
        for a in 0..D {
            self.h[a][l] = r.h[a];
            self.f[a][l] = r.f[a];
            self.t[a][l] = r.t[a];
        }
        self.d[l] = r.d;
        self.sr[l] = r.coefs.sr;
        self.sm[l] = r.coefs.sm;
    }
}

/// [`LANES`] consecutive pairs of a block on their way to the law (SI units): lane m
/// holds the block's lane `off + m` for the `off` given to [`law_block`]. The pair pass
/// fills `n` with x_j - x_i, `v` with v_j - v_i, `r` with
/// the radii and (with rotations) `tmp` with the spins; [`geometry_block`] turns
/// them into the unit normal, the relative velocity at the contact and the overlap.
/// Its rows start on cache lines, as a [`PairBlock`]'s do, each one spare line longer
/// than [`LANES`] ([`LANES_ROW`]).
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub struct Geometry<const D: usize> {
    /// Unit normal from i to j, by component.
    pub n: [[Real; LANES_ROW]; D],
    /// Relative velocity of j's surface w.r.t. i's at the contact, by component.
    pub v: [[Real; LANES_ROW]; D],
    /// Overlap r_i + r_j - |x_j - x_i|: > 0 in contact, <= 0 apart.
    pub d: [Real; LANES_ROW],
    /// Radii r_i, r_j (m).
    pub r: [[Real; LANES_ROW]; 2],
    /// Scratch: the spins of i (columns 0-2) and j (3-5) for [`geometry_block`]
    /// (rad/s; one component each in 2D); then sqrt(d), d^{1/4}, the normal relative
    /// velocity and the normal force, from the law's normal pass to its tangential one
    /// (cheaper to keep than to recompute).
    pub tmp: [[Real; LANES_ROW]; 6],
    /// With rolling resistance: w_j - w_i (rad/s; three components in 3D, the first
    /// in 2D), for [`roll_block`].
    pub wr: [[Real; LANES_ROW]; 3],
}

impl<const D: usize> Default for Geometry<D> {
    fn default() -> Self {
        Geometry {
            n: [[0.0; LANES_ROW]; D],
            v: [[0.0; LANES_ROW]; D],
            d: [0.0; LANES_ROW],
            r: [[0.0; LANES_ROW]; 2],
            tmp: [[0.0; LANES_ROW]; 6],
            wr: [[0.0; LANES_ROW]; 3],
        }
    }
}

crate::cpu::multiversion! {
/// Turns what the pair pass gathered for lanes `lanes` (see [`Geometry`]) into the
/// unit normal, the overlap and the relative velocity of j's surface w.r.t. i's at the
/// contact point, w_j x (-(r_j - d/2) n) - w_i x ((r_i - d/2) n) included when `rot`.
/// Same arithmetic, in the same order, as the nalgebra expressions it replaces (bit
/// for bit). Returns whether some lane is in contact (overlap > 0), and whether some
/// lane's overlap exceeds `max_ratio` (> 0) times its smaller radius.
///
/// Compiled for each instruction-set level (see [`crate::cpu`]).
pub fn geometry_block [const D: usize] (
    g: &mut Geometry<D>,
    lanes: std::ops::Range<usize>,
    rot: bool,
    max_ratio: Real,
) -> (bool, bool) where [] [D] {
    let (lo, hi) = (lanes.start, lanes.end.min(LANES));
    let mut bad = false;
    let mut contact = false;
    for m in lo..hi {
        let (ri, rj) = (g.r[0][m], g.r[1][m]);
        // nalgebra's dot of a 2- or 3-vector: (x0 x0 + x1 x1) + x2 x2
        let mut dist2 = g.n[0][m] * g.n[0][m] + g.n[1][m] * g.n[1][m];
        if D == 3 {
            dist2 += g.n[D - 1][m] * g.n[D - 1][m];
        }
        // dist > 0 always: two centres never coincide within the overlap limit
        let dist = dist2.sqrt();
        let d = ri + rj - dist;
        bad |= d > max_ratio * ri.min(rj);
        contact |= d > 0.0;
        g.d[m] = d;
        // one division per lane, not D: the divider is the law's scarcest unit
        let inv = 1.0 / dist;
        let mut n = [0.0; 3];
        for (a, x) in n.iter_mut().enumerate().take(D) {
            *x = g.n[a][m] * inv;
            g.n[a][m] = *x;
        }
        if rot {
            let (ai, aj) = (ri - 0.5 * d, rj - 0.5 * d);
            if D == 3 {
                let w: [Real; 3] = std::array::from_fn(|c| g.tmp[c][m] * ai + g.tmp[3 + c][m] * aj);
                // w x n, in nalgebra's order
                let wxn = [
                    w[1] * n[2] - w[2] * n[1],
                    w[2] * n[0] - w[0] * n[2],
                    w[0] * n[1] - w[1] * n[0],
                ];
                for (a, x) in wxn.iter().enumerate().take(D) {
                    g.v[a][m] -= x;
                }
            } else {
                // (0, 0, w) x (n0, n1, 0) = (-w n1, w n0)
                let w = g.tmp[0][m] * ai + g.tmp[3][m] * aj;
                g.v[0][m] -= -w * n[1];
                g.v[1][m] -= w * n[0];
            }
        }
    }
    (contact, bad)
}
}

/// Lane `o` of a column of the block behind the raw pointer `b` (`b.h[a][o]`, `b.d[o]`),
/// as a place. No reference to the block is made, so that threads may own different
/// lanes of one block. Only in `unsafe` code, with `o < BLOCK`.
macro_rules! lane {
    ($b:ident . $f:ident [$a:expr] [$o:expr]) => {
        *(&raw mut (*$b).$f[$a]).cast::<Real>().add($o)
    };
    ($b:ident . $f:ident [$o:expr]) => {
        *(&raw mut (*$b).$f).cast::<Real>().add($o)
    };
}

/// What [`law_block`] writes for lanes `lanes` when none of them is in contact:
/// zero history, force, n x f_t and overlap. Cheap when they are zero already (the
/// pairs of a falling layer, which the list holds side by side, for many steps).
///
/// # Safety
/// `b` points to a block, and nothing else reads or writes its lanes `lanes`
/// meanwhile (other lanes may be in use).
pub unsafe fn clear_lanes<const D: usize>(b: *mut PairBlock<D>, lanes: std::ops::Range<usize>) {
    let lanes = lanes.start..lanes.end.min(BLOCK);
    // SAFETY: these lanes are ours (caller), and below BLOCK.
    unsafe {
        // a pair apart has d = 0 and all its state zero; one that just separated has not
        if lanes.clone().all(|o| lane!(b.d[o]) == 0.0) {
            return;
        }
        for o in lanes {
            for a in 0..D {
                lane!(b.h[a][o]) = 0.0;
                lane!(b.f[a][o]) = 0.0;
                lane!(b.t[a][o]) = 0.0;
            }
            lane!(b.d[o]) = 0.0;
        }
    }
}

crate::cpu::multiversion! {
/// Runs the law on the scratch's lanes `lanes`, which are the block's lanes `off +
/// lanes` (`off`: a multiple of [`LANES`] below [`BLOCK`]): for a pair in contact
/// (`g.d > 0`) it advances the history and writes the total force on j, n x f_t (when
/// `torques`, else zero) and the overlap; a pair apart gets all four zero. The lanes
/// outside `lanes` are left alone. Same formulas, in the same order, as
/// `hertz_mindlin_coefs`.
///
/// Compiled for each instruction-set level (see [`crate::cpu`]).
///
/// # Safety
/// `b` points to a block, and nothing else reads or writes its lanes `off + lanes`
/// meanwhile (other threads may own its other lanes: no reference to the whole block
/// is made).
#[allow(clippy::too_many_arguments)]
pub unsafe fn law_block [const D: usize] (
    b: *mut PairBlock<D>,
    g: &mut Geometry<D>,
    lanes: std::ops::Range<usize>,
    off: usize,
    c: &LawConsts,
    dt: Real,
    torques: bool,
) -> () where [] [D] {
    debug_assert!(off.is_multiple_of(LANES) && off < BLOCK);
    // A lane index addresses a dozen columns at once: index loops read best. The masks
    // tell the compiler that m < LANES and off + m < BLOCK.
    let (lo, hi) = (lanes.start, lanes.end.min(LANES));
    let off = off & (BLOCK - LANES);
    let mu = c.mu;
    if c.linear {
        for m in lo..hi {
            let o = off + m;
            let d = g.d[m].max(0.0);
            let mut vn = 0.0;
            for a in 0..D {
                vn += g.v[a][m] * g.n[a][m];
            }
            // SAFETY: lane o < BLOCK is ours (caller).
            let sm = unsafe { lane!(b.sm[o]) };
            // k_n d - 2 xi sqrt(k_n) sqrt(m*) v_n; s = q = 1 (and the factor sr = 1)
            // give the tangential pass k_t and its dashpot unchanged
            g.tmp[3][m] = (c.kn * d - (c.cn * sm) * vn).max(0.0);
            g.tmp[0][m] = 1.0;
            g.tmp[1][m] = 1.0;
            g.tmp[2][m] = vn;
        }
    } else {
        for m in lo..hi {
            let o = off + m;
            // Apart: d <= 0; the law then runs on d = 0 (no NaN) and the result is masked.
            let d = g.d[m].max(0.0);
            let s = d.sqrt();
            let q = s.sqrt();
            let mut vn = 0.0;
            for a in 0..D {
                vn += g.v[a][m] * g.n[a][m];
            }
            // SAFETY: lane o < BLOCK is ours (caller).
            let (sr, sm) = unsafe { (lane!(b.sr[o]), lane!(b.sm[o])) };
            let f_elastic = (2.0 / 3.0) * (c.kn * sr) * s * d;
            g.tmp[3][m] = (f_elastic - (c.cn * sm) * q * vn).max(0.0);
            g.tmp[0][m] = s;
            g.tmp[1][m] = q;
            g.tmp[2][m] = vn;
        }
    }
    if mu <= 0.0 {
        // No friction: no tangential force (a zero f_t, added as with friction: the
        // same bits), no torques, and the history stays as it is (zero in the engine,
        // where mu = 0 holds for the whole run).
        for m in lo..hi {
            let o = off + m;
            // SAFETY: as above.
            unsafe {
                let h: [Real; D] = std::array::from_fn(|a| lane!(b.h[a][o]));
                write_lane(b, g, m, o, false, &[0.0; D], &h);
            }
        }
        return;
    }
    for m in lo..hi {
        let o = off + m;
        let contact = g.d[m] > 0.0;
        // SAFETY: as above.
        let h_old: [Real; D] = std::array::from_fn(|a| unsafe { lane!(b.h[a][o]) });
        // SAFETY: as above.
        let t = unsafe { trial(b, g, m, o, &h_old, c, dt) };
        let f_max = mu * g.tmp[3][m];
        let slide = t.ft2 > f_max * f_max;
        // Sliding caps the force at mu f_n (slide implies ft2 > 0). Both branches run
        // on every lane, selected by the flag: sliding contacts are common while a
        // layer falls, and a separate pass for them cost more than it saved.
        let scale = if slide { f_max / t.ft2.sqrt() } else { 1.0 };
        let ft: [Real; D] = std::array::from_fn(|a| t.ft[a] * scale);
        // sliding: the spring stretch consistent with the capped force (one division,
        // as in the scalar law)
        let inv_kt = 1.0 / t.k_t;
        let h: [Real; D] = std::array::from_fn(|a| {
            if slide {
                -(ft[a] + t.vt[a] * t.c_t) * inv_kt
            } else {
                t.hp[a]
            }
        });
        // SAFETY: as above.
        unsafe { write_lane(b, g, m, o, contact && torques, &ft, &h) };
    }
}
}

/// The sticking trial of the tangential law for one lane (see [`trial`]).
struct Trial<const D: usize> {
    /// Tangential relative velocity (m/s).
    vt: [Real; D],
    /// Projected, rescaled and advanced spring stretch (m).
    hp: [Real; D],
    /// Trial tangential force on j (N) and its squared magnitude.
    ft: [Real; D],
    ft2: Real,
    /// Tangential stiffness (N/m) and damping (N s/m).
    k_t: Real,
    c_t: Real,
}

/// The tangential law's trial for scratch lane m (block lane o), from the history `h`
/// and the normal pass's scratch (sqrt(d), d^{1/4}, v_n in `g.tmp[0..3]`): the stretch
/// projected onto the tangent plane with its magnitude kept, advanced by v_t dt, and
/// the force it gives. Same formulas, in the same order, as `hertz_mindlin_coefs`.
///
/// # Safety
/// Block lane `o` of `b` is the caller's (see [`law_block`]).
#[inline(always)]
unsafe fn trial<const D: usize>(
    b: *mut PairBlock<D>,
    g: &Geometry<D>,
    m: usize,
    o: usize,
    h: &[Real; D],
    c: &LawConsts,
    dt: Real,
) -> Trial<D> {
    let (s, q, vn) = (g.tmp[0][m], g.tmp[1][m], g.tmp[2][m]);
    let mut hn = 0.0;
    let mut h_old2 = 0.0;
    for (a, &x) in h.iter().enumerate() {
        hn += x * g.n[a][m];
        h_old2 += x * x;
    }
    let mut hp = [0.0; D];
    let mut h_new2 = 0.0;
    for (a, x) in hp.iter_mut().enumerate() {
        *x = h[a] - g.n[a][m] * hn;
        h_new2 += *x * *x;
    }
    // Keep the stored elastic displacement's magnitude when projecting it.
    let rescale = if h_new2 > 0.0 {
        (h_old2 / h_new2).sqrt()
    } else {
        1.0
    };
    // SAFETY: lane o is ours (caller).
    let (sr, sm) = unsafe { (lane!(b.sr[o]), lane!(b.sm[o])) };
    let k_t = (c.kt * sr) * s;
    let c_t = (c.ct * sm) * q;
    let mut vt = [0.0; D];
    let mut ft = [0.0; D];
    let mut ft2 = 0.0;
    for a in 0..D {
        vt[a] = g.v[a][m] - g.n[a][m] * vn;
        hp[a] = hp[a] * rescale + vt[a] * dt;
        ft[a] = -(hp[a] * k_t) - vt[a] * c_t;
        ft2 += ft[a] * ft[a];
    }
    Trial {
        vt,
        hp,
        ft,
        ft2,
        k_t,
        c_t,
    }
}

/// Writes the results of scratch lane m into block lane o from its tangential force
/// `ft` and new history `h`: the total force on j, n x f_t (when `torques`, else zero),
/// the history and the overlap; all zero for a pair apart.
///
/// # Safety
/// Block lane `o` of `b` is the caller's (see [`law_block`]).
// A lane index addresses a dozen columns at once: index loops read best.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
unsafe fn write_lane<const D: usize>(
    b: *mut PairBlock<D>,
    g: &Geometry<D>,
    m: usize,
    o: usize,
    torques: bool,
    ft: &[Real; D],
    h: &[Real; D],
) {
    let contact = g.d[m] > 0.0;
    let fnorm = g.tmp[3][m];
    // n and f_t padded to three components (zeros in 2D) for n x f_t
    let mut n3 = [0.0; 3];
    let mut f3 = [0.0; 3];
    for a in 0..D {
        n3[a] = g.n[a][m];
        f3[a] = ft[a];
        // SAFETY: lane o is ours (caller).
        unsafe {
            lane!(b.h[a][o]) = if contact { h[a] } else { 0.0 };
            lane!(b.f[a][o]) = if contact { n3[a] * fnorm + ft[a] } else { 0.0 };
        }
    }
    // the component order of nalgebra's cross product (bit for bit)
    let nxf = [
        n3[1] * f3[2] - n3[2] * f3[1],
        n3[2] * f3[0] - n3[0] * f3[2],
        n3[0] * f3[1] - n3[1] * f3[0],
    ];
    let on = contact && torques;
    // 3D: the three components; 2D: the out-of-plane one
    let (first, count) = if D == 3 { (0, 3) } else { (2, 1) };
    // SAFETY: as above.
    unsafe {
        for k in 0..count {
            lane!(b.t[k][o]) = if on { nxf[first + k] } else { 0.0 };
        }
        lane!(b.d[o]) = if contact { g.d[m] } else { 0.0 };
    }
}

/// The rolling state of [`BLOCK`] consecutive pairs, beside their [`PairBlock`], kept
/// only when the material has rolling resistance: a scene without it stores nothing
/// more per pair. Its rows start on cache lines, as a [`PairBlock`]'s do.
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub struct RollBlock<const D: usize> {
    /// Rolling displacement (m), by component.
    pub h: [[Real; BLOCK_ROW]; D],
    /// R* n x f_r (N m): the moment on j, whose opposite acts on i; three components
    /// in 3D, the out-of-plane one first in 2D. Zero for a pair apart.
    pub m: [[Real; BLOCK_ROW]; D],
}

impl<const D: usize> Default for RollBlock<D> {
    fn default() -> Self {
        RollBlock {
            h: [[0.0; BLOCK_ROW]; D],
            m: [[0.0; BLOCK_ROW]; D],
        }
    }
}

/// One pair's rolling state, as [`RollBlock`] stores it lane by lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollRecord<const D: usize> {
    /// Rolling displacement (m).
    pub h: [Real; D],
    /// R* n x f_r (N m).
    pub m: [Real; D],
}

impl<const D: usize> Default for RollRecord<D> {
    fn default() -> Self {
        RollRecord {
            h: [0.0; D],
            m: [0.0; D],
        }
    }
}

impl<const D: usize> RollBlock<D> {
    /// The state of lane `l` (`l < BLOCK`).
    #[inline]
    pub fn get(&self, l: usize) -> RollRecord<D> {
        RollRecord {
            h: std::array::from_fn(|a| self.h[a][l]),
            m: std::array::from_fn(|a| self.m[a][l]),
        }
    }

    /// Sets the state of lane `l` (`l < BLOCK`).
    #[inline]
    pub fn set(&mut self, l: usize, r: &RollRecord<D>) {
        for a in 0..D {
            self.h[a][l] = r.h[a];
            self.m[a][l] = r.m[a];
        }
    }
}

/// Zeroes the rolling state of lanes `lanes` of the block behind `rb` (pairs apart).
///
/// # Safety
/// As for [`clear_lanes`].
pub unsafe fn clear_roll_lanes<const D: usize>(
    rb: *mut RollBlock<D>,
    lanes: std::ops::Range<usize>,
) {
    let lanes = lanes.start..lanes.end.min(BLOCK);
    // SAFETY: these lanes are ours (caller), and below BLOCK.
    unsafe {
        for o in lanes {
            for a in 0..D {
                lane!(rb.h[a][o]) = 0.0;
                lane!(rb.m[a][o]) = 0.0;
            }
        }
    }
}

crate::cpu::multiversion! {
/// The rolling law ([`rolling_epsd`](super::contact_law::rolling_epsd)) on the
/// scratch's lanes `lanes` after [`law_block`] (whose normal force and normal
/// stiffness factors it reads from `g.tmp` and the block's factors), with the relative
/// spins in `g.wr`: advances each pair's rolling displacement and writes R* n x f_r;
/// pairs apart get zeros. R* comes from the radii in the scratch. Branch-free, as
/// [`law_block`]: both the elastic and the capped results are formed on every lane and
/// selected, so the loop vectorises. Compiled for each instruction-set level (see
/// [`crate::cpu`]).
///
/// # Safety
/// `rb` and `b` point to the blocks of these pairs, whose lanes `off + lanes` nothing
/// else reads or writes meanwhile.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop)]
pub unsafe fn roll_block [const D: usize] (
    rb: *mut RollBlock<D>,
    b: *mut PairBlock<D>,
    g: &Geometry<D>,
    lanes: std::ops::Range<usize>,
    off: usize,
    c: &LawConsts,
    rc: &super::contact_law::RollCoefs,
    dt: Real,
) -> () where [] [D] {
    let (lo, hi) = (lanes.start, lanes.end.min(LANES));
    let off = off & (BLOCK - LANES);
    for m in lo..hi {
        let o = off + m;
        let contact = g.d[m] > 0.0;
        let (ri, rj) = (g.r[0][m], g.r[1][m]);
        let r_eff = ri * rj / (ri + rj);
        let n: [Real; D] = std::array::from_fn(|a| g.n[a][m]);
        // v_r = R* (w_j - w_i) x n
        let mut vr = [0.0; D];
        if D == 3 {
            let w = [g.wr[0][m], g.wr[1][m], g.wr[2][m]];
            let wxn = [
                w[1] * n[2] - w[2] * n[1],
                w[2] * n[0] - w[0] * n[2],
                w[0] * n[1] - w[1] * n[0],
            ];
            for a in 0..D {
                vr[a] = r_eff * wxn[a];
            }
        } else {
            let w = g.wr[0][m];
            vr[0] = r_eff * (-w * n[1]);
            vr[1] = r_eff * (w * n[0]);
        }
        // SAFETY: lane o < BLOCK is ours (caller).
        let (sr, h_old) = unsafe {
            (
                lane!(b.sr[o]),
                std::array::from_fn::<Real, D, _>(|a| lane!(rb.h[a][o])),
            )
        };
        // the normal stiffness: 2 E* sqrt(R*) sqrt(d), or k_n (sr = s = 1)
        let k_n = (c.kn * sr) * g.tmp[0][m];
        let k_r = rc.k_abs + rc.k_rel * k_n;
        let (mut hn, mut h_old2) = (0.0, 0.0);
        for a in 0..D {
            hn += h_old[a] * n[a];
            h_old2 += h_old[a] * h_old[a];
        }
        let mut h = [0.0; D];
        let mut h_new2 = 0.0;
        for a in 0..D {
            h[a] = h_old[a] - n[a] * hn;
            h_new2 += h[a] * h[a];
        }
        let rescale = if h_new2 > 0.0 && h_new2 != h_old2 {
            (h_old2 / h_new2).sqrt()
        } else {
            1.0
        };
        let mut fr = [0.0; D];
        let mut fr2 = 0.0;
        for a in 0..D {
            h[a] = h[a] * rescale + vr[a] * dt;
            fr[a] = -(h[a] * k_r) - vr[a] * rc.gamma;
            fr2 += fr[a] * fr[a];
        }
        let f_max = rc.mu_r * g.tmp[3][m];
        // at the cap: |f_r| = mu_r f_n (slide implies fr2 > 0) and the displacement the
        // capped force implies
        let slide = fr2 > f_max * f_max;
        let scale = if slide { f_max / fr2.sqrt() } else { 1.0 };
        let inv_kr = 1.0 / k_r;
        // without a spring nothing is stored (see `rolling_epsd`)
        let keep = contact && k_r > 0.0;
        for a in 0..D {
            fr[a] *= scale;
            let capped = -(fr[a] + vr[a] * rc.gamma) * inv_kr;
            h[a] = if slide { capped } else { h[a] };
        }
        // R* n x f_r
        let mut mom = [0.0; D];
        if D == 3 {
            mom[0] = r_eff * (n[1] * fr[2] - n[2] * fr[1]);
            mom[1] = r_eff * (n[2] * fr[0] - n[0] * fr[2]);
            mom[2] = r_eff * (n[0] * fr[1] - n[1] * fr[0]);
        } else {
            mom[0] = r_eff * (n[0] * fr[1] - n[1] * fr[0]);
        }
        // SAFETY: as above.
        unsafe {
            for a in 0..D {
                lane!(rb.h[a][o]) = if keep { h[a] } else { 0.0 };
                lane!(rb.m[a][o]) = if contact { mom[a] } else { 0.0 };
            }
        }
    }
}
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::{hertz_mindlin_coefs, LawCoefs, PairParams};
    use crate::math::Vector;
    use rand::{Rng, SeedableRng};

    /// The first-level data cache set (of 64, lines of 64 B: 4 KiB apart map alike)
    /// of the byte at `offset` in a struct. Rows differ by whole lines, so where the
    /// struct lies moves every row's set alike and leaves them distinct or not.
    fn l1_set(offset: usize) -> usize {
        (offset / 64) % 64
    }

    /// The byte offsets in `s` of the rows whose first lanes are `rows`.
    fn offsets<'a, T>(s: &T, rows: impl IntoIterator<Item = &'a Real>) -> Vec<usize> {
        let base = s as *const T as usize;
        rows.into_iter()
            .map(|p| p as *const Real as usize - base)
            .collect()
    }

    /// Lane l of every row of a block, and of the law's scratch, falls in a set of its
    /// own, for every l: rows of exactly BLOCK or LANES f64 would put them in a few
    /// sets (one for a block) and the law would evict its own lines (see
    /// [`BLOCK_ROW`]). Every row starts on a cache line.
    #[test]
    fn the_rows_of_a_block_and_of_the_scratch_start_on_lines_in_different_cache_sets() {
        fn distinct(rows: &[usize], lane: usize) -> bool {
            let mut sets: Vec<usize> = rows.iter().map(|r| l1_set(r + 8 * lane)).collect();
            sets.sort_unstable();
            sets.dedup();
            sets.len() == rows.len()
        }
        let b = PairBlock::<3>::default();
        let block = offsets(
            &b,
            (0..3)
                .flat_map(|a| [&b.h[a][0], &b.f[a][0], &b.t[a][0]])
                .chain([&b.d[0], &b.sr[0], &b.sm[0]]),
        );
        assert_eq!(block.len(), 12);
        let g = Geometry::<3>::default();
        let scratch = offsets(
            &g,
            (0..3)
                .flat_map(|a| [&g.n[a][0], &g.v[a][0]])
                .chain([&g.d[0]])
                .chain((0..2).map(|a| &g.r[a][0]))
                .chain((0..6).map(|a| &g.tmp[a][0]))
                .chain((0..3).map(|a| &g.wr[a][0])),
        );
        assert_eq!(scratch.len(), 18);
        let rb = RollBlock::<3>::default();
        let rolling = offsets(&rb, (0..3).flat_map(|a| [&rb.h[a][0], &rb.m[a][0]]));
        // every row starts on a cache line, in a block wherever it lies
        let heap: Vec<PairBlock<3>> = (0..2).map(|_| PairBlock::default()).collect();
        assert_eq!(&heap[1].f[2][0] as *const Real as usize % 64, 0);
        assert_eq!(&b as *const PairBlock<3> as usize % 64, 0);
        assert_eq!(&g as *const Geometry<3> as usize % 64, 0);
        for r in block.iter().chain(&scratch).chain(&rolling) {
            assert_eq!(r % 64, 0, "a row at offset {r} starts within a cache line");
        }
        for (name, rows) in [
            ("block", &block),
            ("scratch", &scratch),
            ("rolling", &rolling),
        ] {
            for lane in [0, 1, 7, 8, 63, LANES - 1] {
                assert!(
                    distinct(rows, lane),
                    "{name} rows share a set at lane {lane}"
                );
            }
        }
    }

    /// The block law agrees with the scalar law pair by pair, sticking and sliding,
    /// with and without friction, in the block's first and last run of [`LANES`];
    /// pairs apart come out zero whatever history they held, and every block lane
    /// outside the range is left alone.
    #[test]
    fn block_law_matches_the_scalar_law() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let (lo, hi) = (3, LANES - 5);
        for (mu, off) in [(0.0, 0), (0.2, 0), (1.0, 0), (0.2, BLOCK - LANES)] {
            let mut b = PairBlock::<3>::default();
            let mut g = Geometry::<3>::default();
            let consts = LawConsts::new(5.3e7, 1.1e7, 0.1, mu);
            // stale values: overwritten in range, kept outside
            for o in 0..BLOCK {
                b.d[o] = 7.0;
                for a in 0..3 {
                    b.h[a][o] = 1e-5 * (rng.random::<f64>() - 0.5);
                    b.f[a][o] = 7.0;
                    b.t[a][o] = 7.0;
                }
            }
            let mut expect = Vec::new();
            for m in 0..LANES {
                let o = off + m;
                let p = PairParams {
                    r_eff: 0.005 + 0.01 * rng.random::<f64>(),
                    m_eff: 1e-3 + 1e-2 * rng.random::<f64>(),
                    e_star: 5.3e7,
                    g_star: 1.1e7,
                    damping: 0.1,
                    friction: mu,
                };
                let c = LawCoefs::new(&p);
                let n = Vector::<3>::from_fn(|_, _| rng.random::<f64>() - 0.5).normalize();
                let v = Vector::<3>::from_fn(|_, _| rng.random::<f64>() - 0.5);
                let h = Vector::<3>::from_fn(|a, _| b.h[a][o]);
                // one pair in five apart (overlap <= 0, the exact zero included)
                let apart = m % 5 == 0;
                let d = if apart {
                    -1e-5 * rng.random::<f64>()
                } else {
                    1e-5 * rng.random::<f64>() + 1e-9
                };
                let mut h_scalar = h;
                let f = hertz_mindlin_coefs(&c, d, &n, &v, &mut h_scalar, 1e-4);
                expect.push((apart, f, h_scalar, n));
                g.d[m] = d;
                (g.r[0][m], g.r[1][m]) = (0.01 + 0.01 * rng.random::<f64>(), 0.02);
                let pf = PairFactors::new(&p);
                b.sr[o] = pf.sr;
                b.sm[o] = pf.sm;
                for a in 0..3 {
                    g.n[a][m] = n[a];
                    g.v[a][m] = v[a];
                }
            }
            let h_before = b.h;
            // SAFETY: the block is this test's alone.
            unsafe { law_block(&raw mut b, &mut g, lo..hi, off, &consts, 1e-4, true) };
            for o in (0..BLOCK).filter(|o| !(off + lo..off + hi).contains(o)) {
                assert_eq!(b.d[o], 7.0);
                for (a, h0) in h_before.iter().enumerate() {
                    assert_eq!((b.f[a][o], b.t[a][o]), (7.0, 7.0));
                    assert_eq!(b.h[a][o], h0[o]);
                }
            }
            for (m, (apart, f, h, n)) in expect.iter().enumerate().take(hi).skip(lo) {
                let o = off + m;
                if *apart {
                    assert_eq!(b.d[o], 0.0);
                    for a in 0..3 {
                        let got = (b.f[a][o], b.t[a][o], b.h[a][o]);
                        assert_eq!(got, (0.0, 0.0, 0.0));
                    }
                    continue;
                }
                assert_eq!(b.d[o], g.d[m]);
                let tol = 1e-12 * (1.0 + f.normal.abs());
                let total = n * f.normal + f.tangential;
                // n x f_t, from which the gather forms either end's torque
                let nxf = n.cross(&f.tangential);
                for a in 0..3 {
                    assert!((b.f[a][o] - total[a]).abs() <= tol, "mu {mu} m {m}");
                    assert!((b.t[a][o] - nxf[a]).abs() <= tol, "mu {mu} m {m}");
                    assert!(
                        (b.h[a][o] - h[a]).abs() <= 1e-12 * (1e-5 + h.norm()),
                        "mu {mu} m {m} a {a}: {} vs {}",
                        b.h[a][o],
                        h[a]
                    );
                }
            }
        }
    }

    /// The block law under the linear law, and the rolling law after it, agree with
    /// the scalar laws pair by pair (sticking and sliding, rolling elastic and at its
    /// cap, a given and a derived rolling spring); pairs apart come out zero.
    #[test]
    fn linear_and_rolling_block_laws_match_the_scalar_laws() {
        use crate::dynamics::contact_law::{linear_coefs, rolling_epsd, RollCoefs};
        use crate::dynamics::material::Rolling;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (kn, kt, xi, mu) = (2e4, 1.5e4, 0.1, 0.4);
        for (linear, k_r) in [(true, Some(300.0)), (true, None), (false, None)] {
            let consts = if linear {
                LawConsts::linear(kn, kt, xi, mu)
            } else {
                LawConsts::new(5.3e7, 1.1e7, xi, mu)
            };
            let rc = RollCoefs::new(&Rolling::Epsd {
                mu_r: 0.3,
                k_r,
                gamma_r: 1e-3,
            });
            let (mut b, mut rb) = (PairBlock::<3>::default(), RollBlock::<3>::default());
            let mut g = Geometry::<3>::default();
            let mut expect = Vec::new();
            for m in 0..LANES {
                let (ri, rj) = (0.01 + 0.01 * rng.random::<f64>(), 0.015);
                let r_eff = ri * rj / (ri + rj);
                let p = PairParams {
                    r_eff,
                    m_eff: 1e-3 + 1e-2 * rng.random::<f64>(),
                    e_star: 5.3e7,
                    g_star: 1.1e7,
                    damping: xi,
                    friction: mu,
                };
                let n = Vector::<3>::from_fn(|_, _| rng.random::<f64>() - 0.5).normalize();
                let v = Vector::<3>::from_fn(|_, _| rng.random::<f64>() - 0.5);
                let w = Vector::<3>::from_fn(|_, _| 50.0 * (rng.random::<f64>() - 0.5));
                let h0 = Vector::<3>::from_fn(|_, _| 1e-5 * (rng.random::<f64>() - 0.5));
                let hr0 = Vector::<3>::from_fn(|_, _| 1e-4 * (rng.random::<f64>() - 0.5));
                let apart = m % 5 == 0;
                let d = if apart {
                    -1e-5
                } else {
                    1e-4 * rng.random::<f64>() + 1e-9
                };
                let (mut h, mut hr) = (h0, hr0);
                let (f, k_n) = if linear {
                    let c = LawCoefs::linear(&p, kn, kt);
                    (linear_coefs(&c, d, &n, &v, &mut h, 1e-4), kn)
                } else {
                    let c = LawCoefs::new(&p);
                    let f = hertz_mindlin_coefs(&c, d, &n, &v, &mut h, 1e-4);
                    (f, 2.0 * 5.3e7 * (r_eff * d.max(0.0)).sqrt())
                };
                let v_r = w.cross(&n) * r_eff;
                let f_r = rolling_epsd(&rc, f.normal, k_n, &n, &v_r, &mut hr, 1e-4);
                expect.push((apart, f, h, hr, n.cross(&f_r) * r_eff, n));
                g.d[m] = d;
                (g.r[0][m], g.r[1][m]) = (ri, rj);
                let pf = if linear {
                    PairFactors::linear(&p)
                } else {
                    PairFactors::new(&p)
                };
                (b.sr[m], b.sm[m]) = (pf.sr, pf.sm);
                for a in 0..3 {
                    (g.n[a][m], g.v[a][m], g.wr[a][m]) = (n[a], v[a], w[a]);
                    (b.h[a][m], rb.h[a][m]) = (h0[a], hr0[a]);
                }
            }
            // SAFETY: the blocks are this test's alone.
            unsafe {
                law_block(&raw mut b, &mut g, 0..LANES, 0, &consts, 1e-4, true);
                roll_block(&raw mut rb, &raw mut b, &g, 0..LANES, 0, &consts, &rc, 1e-4);
            }
            let mut capped = 0;
            for (m, (apart, f, h, hr, mom, n)) in expect.iter().enumerate() {
                if *apart {
                    for a in 0..3 {
                        assert_eq!((b.f[a][m], rb.h[a][m], rb.m[a][m]), (0.0, 0.0, 0.0));
                    }
                    continue;
                }
                let total = n * f.normal + f.tangential;
                let tol = 1e-10 * (1e-6 + total.norm());
                let mtol = 1e-10 * (1e-12 + mom.norm());
                capped +=
                    usize::from(mom.norm() >= 0.3 * r_eff_of(&g, m) * f.normal * (1.0 - 1e-9));
                for a in 0..3 {
                    assert!((b.f[a][m] - total[a]).abs() <= tol, "{linear} {m}");
                    assert!((b.h[a][m] - h[a]).abs() <= 1e-10 * (1e-9 + h.norm()));
                    assert!((rb.h[a][m] - hr[a]).abs() <= 1e-10 * (1e-9 + hr.norm()));
                    assert!((rb.m[a][m] - mom[a]).abs() <= mtol, "{linear} {m} {a}");
                }
            }
            assert!(
                capped > 0 && capped < LANES * 4 / 5,
                "{capped} lanes at the cap"
            );
        }
    }

    fn r_eff_of(g: &Geometry<3>, m: usize) -> Real {
        g.r[0][m] * g.r[1][m] / (g.r[0][m] + g.r[1][m])
    }

    /// In 2D the block law's n x f_t is the out-of-plane component, in the first
    /// column, and matches the scalar law's tangential force.
    #[test]
    fn block_law_2d_torque_component() {
        let consts = LawConsts::new(5.3e7, 1.1e7, 0.1, 0.5);
        let p = PairParams {
            r_eff: 0.005,
            m_eff: 2e-3,
            e_star: 5.3e7,
            g_star: 1.1e7,
            damping: 0.1,
            friction: 0.5,
        };
        let n = Vector::<2>::new(0.6, 0.8);
        // approaching (v.n < 0) and sliding sideways
        let v = Vector::<2>::new(-0.3, 0.1);
        let mut h = Vector::<2>::new(2e-7, -1e-7);
        let (mut b, mut g) = (PairBlock::<2>::default(), Geometry::<2>::default());
        let pf = PairFactors::new(&p);
        (b.sr[0], b.sm[0], g.d[0]) = (pf.sr, pf.sm, 2e-6);
        (g.r[0][0], g.r[1][0]) = (0.01, 0.02);
        for a in 0..2 {
            (g.n[a][0], g.v[a][0], b.h[a][0]) = (n[a], v[a], h[a]);
        }
        // SAFETY: the block is this test's alone.
        unsafe { law_block(&raw mut b, &mut g, 0..1, 0, &consts, 1e-4, true) };
        let f = hertz_mindlin_coefs(&LawCoefs::new(&p), 2e-6, &n, &v, &mut h, 1e-4);
        let nxf = n[0] * f.tangential[1] - n[1] * f.tangential[0];
        assert!(f.tangential.norm() > 0.0);
        let tol = 1e-14 * f.normal;
        assert!((b.t[0][0] - nxf).abs() <= tol);
        assert_eq!(b.t[1][0], 0.0);
    }

    /// The block geometry equals the nalgebra expressions of a per-pair loop bit for
    /// bit (2D and 3D, with and without rotations), and flags a lane too deep.
    fn geometry_matches_nalgebra<const D: usize>()
    where
        crate::math::Dim<D>: crate::math::Spatial<D>,
    {
        use crate::math::{AngOps, Dim, Spatial};
        type Ang<const D: usize> = <Dim<D> as Spatial<D>>::Ang;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let nc = <Ang<D> as AngOps>::NCOMP;
        for rot in [false, true] {
            let mut g = Geometry::<D>::default();
            let mut expect = Vec::new();
            for m in 0..LANES {
                let (ri, rj) = (
                    0.01 + 0.01 * rng.random::<f64>(),
                    0.01 + 0.01 * rng.random::<f64>(),
                );
                let dx = Vector::<D>::from_fn(|_, _| rng.random::<f64>() - 0.5).normalize()
                    * (ri + rj)
                    * (0.9 + 0.2 * rng.random::<f64>());
                let dv = Vector::<D>::from_fn(|_, _| rng.random::<f64>() - 0.5);
                let wc: Vec<f64> = (0..2 * nc)
                    .map(|_| 10.0 * rng.random::<f64>() - 5.0)
                    .collect();
                let (wi, wj) = (
                    Ang::<D>::from_comps(&wc[..nc]),
                    Ang::<D>::from_comps(&wc[nc..]),
                );
                // the per-pair loop this replaces
                let dist = dx.norm_squared().sqrt();
                let d = ri + rj - dist;
                let n = dx * (1.0 / dist);
                let mut vrel = dv;
                if rot {
                    let w = wi * (ri - 0.5 * d) + wj * (rj - 0.5 * d);
                    vrel -= <Dim<D>>::cross_wv(w, &n);
                }
                expect.push((d, n, vrel));
                (g.r[0][m], g.r[1][m]) = (ri, rj);
                for a in 0..D {
                    (g.n[a][m], g.v[a][m]) = (dx[a], dv[a]);
                }
                for c in 0..nc {
                    (g.tmp[c][m], g.tmp[3 + c][m]) = (wc[c], wc[nc + c]);
                }
            }
            // Centre distances are 0.9-1.1 (r_i + r_j): about half the lanes touch,
            // with overlaps up to 10 % of r_i + r_j. A limit of 0.5 r_min never trips,
            // one of 1e-3 r_min does.
            let lanes = 0..LANES;
            let (contact, bad) = geometry_block(&mut g.clone(), lanes.clone(), rot, 0.5);
            assert!(contact && !bad);
            // all lanes twice as far apart: no contact
            let mut apart = g.clone();
            for col in apart.n.iter_mut() {
                col.iter_mut().for_each(|x| *x *= 2.0);
            }
            assert_eq!(
                geometry_block(&mut apart, lanes.clone(), rot, 1e-3),
                (false, false)
            );
            assert_eq!(geometry_block(&mut g, lanes, rot, 1e-3), (true, true));
            for (m, (d, n, v)) in expect.iter().enumerate() {
                assert_eq!(g.d[m].to_bits(), d.to_bits());
                for a in 0..D {
                    assert_eq!(g.n[a][m].to_bits(), n[a].to_bits());
                    assert_eq!(g.v[a][m].to_bits(), v[a].to_bits(), "rot {rot} m {m} a {a}");
                }
            }
        }
    }

    #[test]
    fn geometry_block_matches_nalgebra_3d() {
        geometry_matches_nalgebra::<3>();
    }

    #[test]
    fn geometry_block_matches_nalgebra_2d() {
        geometry_matches_nalgebra::<2>();
    }
}
