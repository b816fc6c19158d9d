//! Runtime CPU dispatch of the BVH traversal: the one module of the workspace with `unsafe`.
//!
//! The generic x86-64 baseline has only SSE2, where an eight-child node test runs as two
//! four-lane halves (glam `Vec4`). On CPUs with AVX2 (and FMA, BMI1/2, LZCNT, POPCNT, which
//! every AVX2 CPU has) the whole query — traversal, node tests, triangle tests — is compiled
//! a second time with those features enabled and the node test becomes one eight-lane
//! compare; with AVX-512 (F + VL) a third time, letting the compiler use EVEX encodings and
//! mask registers for the same eight-lane kernel (measured no faster than AVX2, so not the
//! default: [`SimdLevel::detected`]). The level is picked once per scene from
//! `is_x86_feature_detected!` and can be forced (for measurement) with the environment
//! variable `SPECTRACE_SIMD=sse2|avx2|avx512` or [`crate::Scene::set_simd_level`]; the scene
//! holds it as a [`Supported`] level, which only a successful CPU check can build, so the
//! per-ray [`dispatch`] trusts it without checking again.
//!
//! Every level performs the same IEEE operations in the same order (Rust never contracts
//! `a·b + c` into an FMA, and the eight-lane node test is the four-lane one, lane for lane),
//! so all levels return bit-identical hits; `tests/it/intersection.rs` checks this on the
//! same rays for every level the CPU supports.

#![allow(unsafe_code)]

use std::sync::OnceLock;

use glam::Vec4;

use crate::wide::WideNode;

/// An instruction-set level of the traversal kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SimdLevel {
    /// The x86-64 baseline (SSE2): node tests in two four-lane halves. Portable code on other
    /// architectures.
    Sse2,
    /// AVX2 + FMA (with BMI1/2, LZCNT, POPCNT): eight-lane node tests.
    Avx2,
    /// AVX-512 F + VL on top of `Avx2`: the same eight-lane kernel compiled with EVEX
    /// encodings and mask registers. Run only when asked for ([`SimdLevel::detected`]).
    Avx512,
}

impl SimdLevel {
    /// Every level, narrowest first.
    pub const ALL: [SimdLevel; 3] = [SimdLevel::Sse2, SimdLevel::Avx2, SimdLevel::Avx512];

    /// Whether this CPU can run the level.
    pub fn is_supported(self) -> bool {
        match self {
            SimdLevel::Sse2 => true,
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => {
                is_x86_feature_detected!("avx2")
                    && is_x86_feature_detected!("fma")
                    && is_x86_feature_detected!("bmi1")
                    && is_x86_feature_detected!("bmi2")
                    && is_x86_feature_detected!("lzcnt")
                    && is_x86_feature_detected!("popcnt")
            }
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => {
                SimdLevel::Avx2.is_supported()
                    && is_x86_feature_detected!("avx512f")
                    && is_x86_feature_detected!("avx512vl")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The levels this CPU supports, narrowest first (SSE2 always; AVX2 and AVX-512 where present).
    pub fn supported() -> impl Iterator<Item = SimdLevel> {
        SimdLevel::ALL.into_iter().filter(|l| l.is_supported())
    }

    /// The fastest level this CPU supports: AVX2 where it is present, AVX-512 or not, else SSE2.
    /// The AVX-512 level is the same eight-lane kernel in EVEX encodings; it has measured no
    /// faster than AVX2 on any row of `traversal_table` on the two AVX-512 machines it was
    /// measured on (an AMD EPYC and an Intel Xeon; 1–11 % slower on the Xeon, and
    /// 2.5–3.5 % slower end to end: `docs/perf.md`), so it runs only when asked for.
    pub(crate) fn detected() -> SimdLevel {
        if SimdLevel::Avx2.is_supported() { SimdLevel::Avx2 } else { SimdLevel::Sse2 }
    }

    /// The level new scenes use: `SPECTRACE_SIMD` if set to a supported level (a one-line
    /// warning otherwise), else the fastest level this CPU supports (AVX2 where present, see
    /// [`SimdLevel::detected`]). Read once per process.
    pub fn default_level() -> SimdLevel {
        Supported::default_level().level()
    }

    /// The level's name as `SPECTRACE_SIMD` spells it.
    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Sse2 => "sse2",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Avx512 => "avx512",
        }
    }
}

/// A [`SimdLevel`] this CPU supports: built only by [`Supported::new`] after
/// [`SimdLevel::is_supported`] (the field is private to this module), so holding one is the
/// proof [`dispatch`] relies on and the CPU is checked once per scene, not once per ray.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Supported(SimdLevel);

impl Supported {
    /// `level`, if this CPU can run it.
    pub(crate) fn new(level: SimdLevel) -> Option<Self> {
        level.is_supported().then_some(Self(level))
    }

    /// The level.
    pub(crate) fn level(self) -> SimdLevel {
        self.0
    }

    /// See [`SimdLevel::default_level`].
    pub(crate) fn default_level() -> Self {
        static LEVEL: OnceLock<Supported> = OnceLock::new();
        *LEVEL.get_or_init(|| {
            // SSE2 is the x86-64 baseline (and the portable path elsewhere): always supported.
            let detected = Supported::new(SimdLevel::detected()).unwrap_or(Supported(SimdLevel::Sse2));
            let Ok(asked) = std::env::var("SPECTRACE_SIMD") else { return detected };
            let d = detected.level();
            match SimdLevel::ALL.iter().find(|l| l.name() == asked.trim().to_ascii_lowercase()) {
                Some(&level) => Supported::new(level).unwrap_or_else(|| {
                    eprintln!("warning: SPECTRACE_SIMD={asked}: this CPU lacks {level:?}; using {d:?}");
                    detected
                }),
                None => {
                    eprintln!("warning: SPECTRACE_SIMD={asked} is not one of sse2, avx2, avx512; using {d:?}");
                    detected
                }
            }
        })
    }
}

/// The eight slab tests of a node: entry distances and the mask of children hit. Every
/// implementation computes, lane for lane, `t0 = max(max(x0, y0), max(z0, 0))` and
/// `t1 = min(min(x1, y1), min(z1, t_max)) · far_scale` with `x0 = (near_x − o_x) · inv_x`
/// etc., and hits where `t0 ≤ t1` (see `wide.rs` for why this is conservative).
pub(crate) trait NodeTest: Copy {
    fn test(self, node: &WideNode, ray: &NodeRay, t_max: f32) -> ([f32; 8], u32);
}

/// Per-ray inputs of the node test.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NodeRay {
    pub(crate) origin: [f32; 3],
    pub(crate) inv: [f32; 3],
    /// Which of `bounds[2a]`, `bounds[2a + 1]` is the near plane on axis a.
    pub(crate) near: [usize; 3],
    pub(crate) far_scale: f32,
}

/// Two four-lane halves in glam `Vec4` (SSE2 on x86-64).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sse2;

impl NodeTest for Sse2 {
    #[inline(always)]
    fn test(self, node: &WideNode, ray: &NodeRay, t_max: f32) -> ([f32; 8], u32) {
        let b = &node.bounds;
        let [ox, oy, oz] = ray.origin.map(Vec4::splat);
        let [ix, iy, iz] = ray.inv.map(Vec4::splat);
        let near = ray.near;
        let (t_max, far_scale) = (Vec4::splat(t_max), Vec4::splat(ray.far_scale));
        let mut tn = [0f32; 8];
        let mut mask = 0u32;
        for half in 0..2 {
            let l = |plane: usize| Vec4::from_slice(&b[plane][4 * half..4 * half + 4]);
            // Vec4::max/min are single SSE max/min instructions; no NaN can occur (see
            // `WideBvh::traverse`), so their NaN convention does not matter.
            let x0 = (l(near[0]) - ox) * ix;
            let y0 = (l(2 + near[1]) - oy) * iy;
            let z0 = (l(4 + near[2]) - oz) * iz;
            let x1 = (l(1 - near[0]) - ox) * ix;
            let y1 = (l(3 - near[1]) - oy) * iy;
            let z1 = (l(5 - near[2]) - oz) * iz;
            let t0 = x0.max(y0).max(z0.max(Vec4::ZERO));
            let t1 = x1.min(y1).min(z1.min(t_max)) * far_scale;
            t0.write_to_slice(&mut tn[4 * half..4 * half + 4]);
            mask |= t0.cmple(t1).bitmask() << (4 * half);
        }
        (tn, mask)
    }
}

/// One eight-lane AVX test. Only `run_avx2`/`run_avx512` create it, and only [`dispatch`] calls
/// them, for a [`Supported`] level of AVX2 or above, so holding one proves AVX2 is available.
#[cfg(target_arch = "x86_64")]
#[derive(Debug, Clone, Copy)]
pub(crate) struct Avx2 {
    _proof: (),
}

#[cfg(target_arch = "x86_64")]
impl NodeTest for Avx2 {
    #[inline(always)]
    fn test(self, node: &WideNode, ray: &NodeRay, t_max: f32) -> ([f32; 8], u32) {
        // SAFETY: an `Avx2` exists only inside `run_avx2`/`run_avx512`, which `dispatch` calls
        // only for a `Supported` AVX2 or AVX-512 level; `Supported::new` built that level after
        // `SimdLevel::is_supported` confirmed AVX2 (which implies AVX) on this CPU.
        unsafe { node_test_avx2(node, ray, t_max) }
    }
}

/// Always inlined and without `#[target_feature]` of its own (the two cannot be combined), so
/// that it is compiled into `run_avx2`/`run_avx512`, whose features its intrinsics then inline
/// into. As a `#[target_feature]` function it stayed out of line, a call per node: 13 % of
/// the traversal's time, and the AVX2 level no faster than SSE2. Every function between
/// `run_avx2` and here must be inlined too (closures included): one left out of line has no
/// AVX features, and each intrinsic becomes a call of its own (slow, still correct).
///
/// # Safety
/// The CPU must support AVX (the intrinsics are AVX's; the `Avx2` proof guarantees AVX2).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn node_test_avx2(node: &WideNode, ray: &NodeRay, t_max: f32) -> ([f32; 8], u32) {
    // SAFETY: the caller guarantees AVX2 (this function's contract); the loads and the store
    // are unaligned and stay inside `bounds` rows and `tn` (8 f32 each).
    unsafe {
        use std::arch::x86_64::*;
        let b = &node.bounds;
        let l = |plane: usize| _mm256_loadu_ps(b[plane].as_ptr());
        let [ox, oy, oz] = ray.origin.map(|v| _mm256_set1_ps(v));
        let [ix, iy, iz] = ray.inv.map(|v| _mm256_set1_ps(v));
        let near = ray.near;
        // Same operand order as the SSE2 halves (max(a, b) returns b on ties), so equal lanes
        // give equal bits.
        let x0 = _mm256_mul_ps(_mm256_sub_ps(l(near[0]), ox), ix);
        let y0 = _mm256_mul_ps(_mm256_sub_ps(l(2 + near[1]), oy), iy);
        let z0 = _mm256_mul_ps(_mm256_sub_ps(l(4 + near[2]), oz), iz);
        let x1 = _mm256_mul_ps(_mm256_sub_ps(l(1 - near[0]), ox), ix);
        let y1 = _mm256_mul_ps(_mm256_sub_ps(l(3 - near[1]), oy), iy);
        let z1 = _mm256_mul_ps(_mm256_sub_ps(l(5 - near[2]), oz), iz);
        let t0 = _mm256_max_ps(_mm256_max_ps(x0, y0), _mm256_max_ps(z0, _mm256_setzero_ps()));
        let t1 = _mm256_mul_ps(
            _mm256_min_ps(_mm256_min_ps(x1, y1), _mm256_min_ps(z1, _mm256_set1_ps(t_max))),
            _mm256_set1_ps(ray.far_scale),
        );
        let mut tn = [0f32; 8];
        _mm256_storeu_ps(tn.as_mut_ptr(), t0);
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32;
        (tn, mask)
    }
}

/// A query generic over the node test, run at the scene's level by [`dispatch`].
pub(crate) trait Kernel {
    type Output;
    /// Must be `#[inline(always)]`, so that the whole query is compiled for the level.
    fn run<N: NodeTest>(self, node_test: N) -> Self::Output;
}

/// Run `kernel` with the node test and code generation of `level`. No CPU check here: a
/// [`Supported`] level was checked when it was built.
#[inline(always)]
pub(crate) fn dispatch<K: Kernel>(level: Supported, kernel: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    match level.0 {
        SimdLevel::Avx512 => {
            // SAFETY: `Supported(Avx512)` is built only by `Supported::new` after
            // `SimdLevel::Avx512.is_supported()`, which checks AVX-512 F/VL and everything
            // `Avx2.is_supported()` checks (AVX2, FMA, BMI1/2, LZCNT, POPCNT): all `run_avx512` enables.
            return unsafe { run_avx512(kernel) };
        }
        SimdLevel::Avx2 => {
            // SAFETY: `Supported(Avx2)` is built only by `Supported::new` after
            // `SimdLevel::Avx2.is_supported()` detected AVX2, FMA, BMI1/2, LZCNT, POPCNT: all
            // `run_avx2` enables.
            return unsafe { run_avx2(kernel) };
        }
        SimdLevel::Sse2 => {}
    }
    // Elsewhere only SSE2 (the portable path) is ever supported.
    let _ = level;
    kernel.run(Sse2)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
fn run_avx2<K: Kernel>(kernel: K) -> K::Output {
    kernel.run(Avx2 { _proof: () })
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
fn run_avx512<K: Kernel>(kernel: K) -> K::Output {
    kernel.run(Avx2 { _proof: () })
}

/// The three lanes of `v` truncated to integers, each clamped to `0..=max` first (NaN gives
/// `max`): the bin indices of the BVH build's binning (`sah.rs`), where a saturating
/// float-to-integer cast per lane (`as u32`: a conversion, a compare and a select each) was the
/// largest single cost. One SSE2 `cvttps2dq` converts all lanes; after the clamp every lane is
/// in range, where truncation is what `as` gives.
#[inline(always)]
pub(crate) fn truncate_clamped(v: glam::Vec3A, max: f32) -> [u32; 3] {
    // `min` before `max`: x86 `minps` returns its second operand for a NaN lane.
    let v = v.min(glam::Vec3A::splat(max)).max(glam::Vec3A::ZERO);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128, __m128i, _mm_cvttps_epi32};
        // SAFETY: SSE2 is part of the x86-64 baseline; the conversion has no other precondition.
        let i: __m128i = unsafe { _mm_cvttps_epi32(__m128::from(v)) };
        // SAFETY: __m128i and [i32; 4] have the same size, and every bit pattern is an i32.
        let lanes: [i32; 4] = unsafe { std::mem::transmute::<__m128i, [i32; 4]>(i) };
        [lanes[0] as u32, lanes[1] as u32, lanes[2] as u32]
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        v.as_uvec3().to_array()
    }
}

#[cfg(test)]
mod truncate_tests {
    use super::truncate_clamped;
    use glam::Vec3A;

    #[test]
    fn truncation_matches_the_saturating_cast_in_range_and_clamps_outside() {
        for x in [0.0f32, 0.999_999_9, 1.0, 2.5, 3.0, 14.999_999, 15.0, 15.5, 1e30, f32::INFINITY] {
            let expected = (x as u32).min(15);
            assert_eq!(truncate_clamped(Vec3A::new(x, x, x), 15.0), [expected; 3], "{x}");
        }
        assert_eq!(truncate_clamped(Vec3A::new(-3.0, f32::NAN, 7.9), 15.0), [0, 15, 7]);
    }
}
