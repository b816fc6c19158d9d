//! Our traversal of obvhs's eight-wide BVH: obvhs builds the compressed wide BVH (CWBVH,
//! Ylitie et al. 2017) and we decode each node once into full-precision child boxes in
//! structure-of-arrays form, so a node test is eight slab tests on rows of eight lanes (no
//! per-node dequantisation of 48 bytes, as obvhs's own traversal does). The node test itself
//! lives in `simd.rs` (SSE2 halves, or one AVX2 eight-lane test, picked per scene); this module
//! is the layout and the traversal loop, generic over it.
//! Children are visited nearest first and stack entries carry their entry distance, so
//! subtrees behind the closest hit so far are skipped when popped.
//!
//! Measured and rejected (session 13, `docs/perf.md`): software prefetch of pushed nodes and of
//! hit leaves' triangles, and the reciprocals as one four-lane division, all within noise.
//!
//! Measured and rejected (1M-triangle benchmark, one thread, same-session A/B runs):
//! re-quantising the child boxes to 8 bits per plane (108-byte nodes instead of 224, decoded
//! with vectorised u8 → f32 conversion) was ~24 % slower on primary and incoherent rays: the
//! traversal is bound by instructions more than by memory here; visiting children in
//! obvhs's octant slot order instead of sorting by entry distance was equal within noise;
//! obvhs's `slow_build` preset gave no faster traversal for 1.8× the build time.
//!
//! Also measured (callgrind instruction counts on a 100k-triangle terrain, 256² primary rays
//! and their incoherent bounces; then the 1M benchmark): the leaves of obvhs's CWBVH are
//! small here (1M terrain: 58 % one, 35 % two, 7 % three triangles, 1.49 on average), and
//! node tests plus traversal bookkeeping are ~80 % of the instructions, triangle tests ~20 %.
//! A four-lane SIMD Woop test of a leaf's triangles (bit-identical to the scalar test) cost
//! 17 % *more* triangle-test instructions than one scalar test per triangle when used on
//! every leaf (primary rays fell from 1.35× to 1.16× obvhs's own traversal); used only on
//! leaves of two and three triangles it saved 1–2 % of all instructions, too little for its
//! ~200 lines: rejected. A smaller inline stack (32 entries instead of 64: it is zeroed per
//! ray, and a deeper stack spills to the heap) saved 1 %: kept. obvhs's
//! `reinsertion_batch_ratio` 0.5 instead of medium_build's 0.05 cut traversal instructions by a further 5 % but tripled
//! the build time (0.77 s → 2.7 s single-core on 1M triangles): rejected; PLOC search
//! distance 24/32 and max_prims_per_leaf 1/2 were equal or worse. The SSE2 node test
//! compiles to ~50 instructions for eight children. The `b·inv − o·inv` form is not used
//! even at the AVX2 level, where FMA is available: every level must return bit-identical hits
//! (`simd.rs`), and SSE2 has no FMA; without FMA that form saves nothing and would need a
//! looser error bound.
//!
//! The slab test is made conservative as in Ize, "Robust BVH Ray Traversal" (JCGT 2(2), 2013):
//! the far distance is scaled by 1 + 2γ(3), which covers the rounding of `(b − o) · (1/d)`,
//! so a box test can never cull a ray that the watertight triangle test would hit. obvhs's own
//! node test also clamps the entry distance to a scene-scale ε = 1e-4 (`cwbvh/node.rs`
//! `EPSILON`), which culls every box closer than 1e-4 along the ray; here entry is clamped to 0.

use obvhs::cwbvh::CwBvh;

use crate::ray::gamma;
use crate::simd::{NodeRay, NodeTest};

/// Ize 2013, §3: scaling the far distance by 1 + 2γ(3) covers the rounding of the slab
/// distances (one subtraction, one product with a rounded reciprocal). Evaluated at compile
/// time with the same IEEE operations as at run time, so the bits are those of the expression.
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// Marks an empty child slot (its bounds are inverted, so it is never hit either).
const EMPTY: u32 = u32::MAX;
/// Set in a child reference that is a leaf: bits 29–30 hold count − 1, bits 0–28 the first
/// primitive slot.
const LEAF: u32 = 1 << 31;
const LEAF_START_BITS: u32 = 29;
/// Largest primitive slot a leaf reference can address.
pub(crate) const MAX_PRIMITIVES: usize = 1 << LEAF_START_BITS;

/// Eight children's boxes (min/max per axis, structure of arrays: one row of eight lanes per
/// plane) and references.
/// 224 bytes = 7·32, so `align(32)` adds no padding and keeps every 32-byte row (one AVX
/// register) inside one 64-byte line. (Aligning it to 64-byte lines, 256 bytes, measured 14%
/// slower on incoherent rays on the 1M-triangle benchmark: memory volume matters more than
/// line splits.)
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
pub(crate) struct WideNode {
    /// `bounds[2·axis]` = minima, `bounds[2·axis + 1]` = maxima of the eight children.
    pub(crate) bounds: [[f32; 8]; 6],
    children: [u32; 8],
}

const _: () = assert!(std::mem::size_of::<WideNode>() == 224 && std::mem::align_of::<WideNode>() == 32);

/// The decoded wide BVH; node 0 is the root.
#[derive(Debug, Clone, Default)]
pub(crate) struct WideBvh {
    nodes: Vec<WideNode>,
}

impl WideBvh {
    /// Decode obvhs's CWBVH. Child boxes are dequantised (`p + q·2^e`, exact products) and
    /// rounded outward, so each still contains its child's quantised (and thus conservative)
    /// box. Leaves hold at most 3 primitives (obvhs clamps `max_prims_per_leaf` to 1..=3).
    /// `scale` (1 or a power of two) multiplies every box: the factor the tree was built at
    /// (`bvh.rs` `build_scaled`), undone exactly.
    pub(crate) fn from_cwbvh(cwbvh: &CwBvh, scale: f32) -> Self {
        let nodes = cwbvh
            .nodes
            .iter()
            .map(|node| {
                let mut bounds = [
                    [f32::INFINITY; 8],
                    [f32::NEG_INFINITY; 8],
                    [f32::INFINITY; 8],
                    [f32::NEG_INFINITY; 8],
                    [f32::INFINITY; 8],
                    [f32::NEG_INFINITY; 8],
                ];
                let mut children = [EMPTY; 8];
                for child in 0..8 {
                    if node.is_child_empty(child) {
                        continue;
                    }
                    let aabb = node.child_aabb(child);
                    for axis in 0..3 {
                        bounds[2 * axis][child] = (aabb.min[axis] * scale).next_down();
                        bounds[2 * axis + 1][child] = (aabb.max[axis] * scale).next_up();
                    }
                    children[child] = if node.is_leaf(child) {
                        let (start, count) = node.child_primitives(child);
                        debug_assert!((1..=3).contains(&count) && (start as usize) < MAX_PRIMITIVES);
                        LEAF | ((count - 1) << LEAF_START_BITS) | start
                    } else {
                        node.child_node_index(child)
                    };
                }
                WideNode { bounds, children }
            })
            .collect();
        Self { nodes }
    }

    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Every primitive slot the leaves refer to, in node order (for tests of the tree's shape).
    #[cfg(test)]
    pub(crate) fn leaf_slots(&self) -> Vec<usize> {
        let mut slots = Vec::new();
        for node in &self.nodes {
            for &c in &node.children {
                if c != EMPTY && c & LEAF != 0 {
                    let start = (c & (MAX_PRIMITIVES as u32 - 1)) as usize;
                    slots.extend(start..start + ((c >> LEAF_START_BITS) & 3) as usize + 1);
                }
            }
        }
        slots
    }

    pub(crate) fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode>()
    }

    /// Visit the leaves a ray may hit in (0, `t_max`], nearest first when `closest`.
    /// `leaf(start, count, t_max)` tests primitive slots `start..start + count` and returns
    /// the new `t_max` (smaller after a hit), or `None` to stop traversal (any-hit found).
    #[inline(always)]
    pub(crate) fn traverse<const CLOSEST: bool, N: NodeTest>(
        &self,
        node_test: N,
        origin: [f32; 3],
        dir: [f32; 3],
        mut t_max: f32,
        mut leaf: impl FnMut(usize, usize, f32) -> Option<f32>,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        // Exact reciprocals; a zero component gets a huge finite value so that (b − o)·inv
        // never forms 0·∞ = NaN, and near/far planes are chosen by the reciprocal's sign so
        // ±0 components are handled alike.
        let inv = dir.map(|d| {
            let r = 1.0 / d;
            if r.is_finite() { r } else { 1e30f32.copysign(r) }
        });
        // Which of bounds[2a], bounds[2a+1] is the near plane on each axis.
        let near = inv.map(|r| usize::from(r < 0.0));
        let ray = NodeRay { origin, inv, near, far_scale: FAR_SCALE };

        let mut stack = Stack::new();
        let mut current = 0u32; // the root, an inner node
        loop {
            if current & LEAF == 0 {
                let node = &self.nodes[current as usize];
                let (tn, mask) = node_test.test(node, &ray, t_max);
                if mask == 0 {
                    match pop::<CLOSEST>(&mut stack, t_max) {
                        Some(next) => current = next,
                        None => return,
                    }
                    continue;
                }
                // One child hit (the common case low in the tree): descend without the stack.
                // (`mask & (mask − 1)` rather than count_ones: x86-64 has no POPCNT baseline.)
                let first = mask.trailing_zeros() as usize;
                let rest = mask & (mask - 1);
                if rest == 0 {
                    current = node.children[first];
                    continue;
                }
                // Two children hit (the common case above that): visit the nearer, push the
                // other, without the sort below; the same order as the sort (on a tie, or
                // without sorting for any-hit, the higher slot is visited first).
                if rest & (rest - 1) == 0 {
                    let second = rest.trailing_zeros() as usize;
                    let (a, b) = ((node.children[first], tn[first]), (node.children[second], tn[second]));
                    let (near, far) = if CLOSEST && a.1 < b.1 { (a, b) } else { (b, a) };
                    stack.push(far);
                    current = near.0;
                    continue;
                }
                let mut entries = [(0u32, 0f32); 8];
                let mut count = 0;
                let mut bits = mask;
                while bits != 0 {
                    let i = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    entries[count] = (node.children[i], tn[i]);
                    count += 1;
                }
                if CLOSEST {
                    // Insertion sort, farthest first: push all but the nearest, visit it now.
                    for i in 1..count {
                        let e = entries[i];
                        let mut j = i;
                        while j > 0 && entries[j - 1].1 < e.1 {
                            entries[j] = entries[j - 1];
                            j -= 1;
                        }
                        entries[j] = e;
                    }
                }
                for &e in &entries[..count - 1] {
                    stack.push(e);
                }
                current = entries[count - 1].0;
            } else {
                let start = (current & (MAX_PRIMITIVES as u32 - 1)) as usize;
                let count = ((current >> LEAF_START_BITS) & 3) as usize + 1;
                match leaf(start, count, t_max) {
                    Some(t) => t_max = t,
                    None => return,
                }
                match pop::<CLOSEST>(&mut stack, t_max) {
                    Some(next) => current = next,
                    None => return,
                }
            }
        }
    }
}

/// Next subtree to visit; closest-hit skips entries that start beyond the current hit.
#[inline(always)]
fn pop<const CLOSEST: bool>(stack: &mut Stack, t_max: f32) -> Option<u32> {
    while let Some((node, t)) = stack.pop() {
        // t_max may have shrunk since the push. Entry distances are rounded, so compare with
        // the same conservative scale as the node test rather than exactly.
        if !CLOSEST || t <= t_max * FAR_SCALE {
            return Some(node);
        }
    }
    None
}

/// Traversal stack: a fixed array (no allocation per ray) that spills to the heap only in a
/// pathologically deep tree, so no depth limit can drop a subtree.
struct Stack {
    inline: [(u32, f32); INLINE_STACK],
    len: usize,
    spill: Vec<(u32, f32)>,
}

/// Seven pushes per level at most: 32 entries cover four full levels of eight-wide nodes,
/// and far more in practice (most nodes hit one or two children); deeper stacks spill to the
/// heap. It is zeroed per ray, so a larger one costs time on every ray (64 entries measured
/// 1 % more instructions).
const INLINE_STACK: usize = 32;

impl Stack {
    #[inline(always)]
    fn new() -> Self {
        Self { inline: [(0, 0.0); INLINE_STACK], len: 0, spill: Vec::new() }
    }
    #[inline(always)]
    fn push(&mut self, e: (u32, f32)) {
        if self.len < INLINE_STACK {
            self.inline[self.len] = e;
            self.len += 1;
        } else {
            self.spill.push(e);
        }
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if let Some(e) = self.spill.pop() {
            return Some(e);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.inline[self.len])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stack_spills_to_the_heap_and_stays_last_in_first_out() {
        let mut stack = Stack::new();
        let n = 3 * INLINE_STACK as u32;
        for i in 0..n {
            stack.push((i, i as f32));
        }
        assert_eq!(stack.spill.len(), n as usize - INLINE_STACK);
        for i in (0..n).rev() {
            assert_eq!(stack.pop(), Some((i, i as f32)));
        }
        assert_eq!(stack.pop(), None);
    }

    #[test]
    fn far_scale_constant_has_the_bits_of_the_run_time_expression() {
        let n = std::hint::black_box(3);
        assert_eq!(FAR_SCALE.to_bits(), (1.0 + 2.0 * gamma(n)).to_bits());
        const { assert!(FAR_SCALE > 1.0 && FAR_SCALE < 1.0 + 1e-6) };
    }

    #[test]
    fn closest_traversal_skips_subtrees_behind_the_hit() {
        // Pop with t_max = 1: the entry at t = 2 is skipped, the one at t = 0.5 returned.
        let mut stack = Stack::new();
        stack.push((7, 0.5));
        stack.push((9, 2.0));
        assert_eq!(pop::<true>(&mut stack, 1.0), Some(7));
        stack.push((9, 2.0));
        assert_eq!(pop::<false>(&mut stack, 1.0), Some(9), "any-hit visits everything");
    }
}
