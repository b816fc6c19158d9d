//! Our eight-wide BVH and its traversal. `sah.rs` builds a binary BVH (binned SAH; obvhs's PLOC
//! and reinsertion before), which we collapse into eight-wide nodes by a surface-area cost ([`WideBvh::from_bvh2`]):
//! full-precision child boxes in structure-of-arrays form, so a node test is eight slab tests
//! on rows of eight lanes, and leaves of up to eight primitives; `bvh.rs` stores a leaf of three
//! to eight triangles as one or two four-lane packets (`triangle.rs` `TrianglePacket`), a
//! smaller one as single triangles. The node test itself lives in `simd.rs` (SSE2 halves, or
//! one AVX2 eight-lane test, picked per scene); this module is the layout and the traversal
//! loop, generic over it. Children are visited nearest first and stack entries carry their entry
//! distance, so subtrees behind the closest hit so far are skipped when popped.
//!
//! Originally the tree was obvhs's compressed wide BVH (CWBVH, Ylitie et al. 2017),
//! decoded node by node. Its leaves hold at most three primitives (the format's limit) and were
//! small (1M terrain: 1.49 triangles on average), and one scalar watertight test per triangle
//! was cheaper than a four-lane test of so few. Our own collapse with the same cost
//! reproduces obvhs's tree (10 673 nodes on the 100k terrain, both); costing a leaf of three
//! or four as one four-lane test (`bvh.rs` `build_scaled`) gives a third fewer nodes (10 673
//! → 7 110; 1M terrain 106 224 → 70 488). Against the CWBVH, `traversal_table` at AVX2 (1
//! thread, median ratio of 6 interleaved pairs of runs): primary/incoherent/any-hit
//! ×1.08/1.19/1.19 on the 100k terrain, ×1.07/1.14/1.19 on 1M, ×1.13/1.23/1.25 on the 1.3M
//! icosphere, ×1.07/1.16/1.11 instanced, for 60 bytes per triangle instead of 64.
//!
//! Measured and rejected (`docs/perf.md`): software prefetch of pushed nodes and of
//! hit leaves' triangles, and the reciprocals as one four-lane division, all within noise.
//! On our own layout, prefetch (three lines) of each leaf's singles or packet when it is pushed,
//! ×0.95–1.02 at AVX2 (5 pairs per scene, the same binary switched): within noise.
//!
//! Measured and rejected on the CWBVH (1M-triangle benchmark, one thread, same-session A/B
//! runs): re-quantising the child boxes to 8 bits per plane (108-byte nodes instead of 224,
//! decoded with vectorised u8 → f32 conversion) was ~24 % slower on primary and incoherent
//! rays: the traversal is bound by instructions more than by memory here; visiting children in
//! obvhs's octant slot order instead of sorting by entry distance was equal within noise;
//! obvhs's `slow_build` preset gave no faster traversal for 1.8× the build time; its
//! `reinsertion_batch_ratio` 0.5 instead of medium_build's 0.05 cut traversal instructions by
//! 5 % but tripled the build time (0.77 s → 2.7 s single-core on 1M triangles); PLOC search
//! distance 24/32 was equal or worse. A smaller inline stack (32 entries instead of 64: it is
//! zeroed per ray, and a deeper stack spills to the heap) saved 1 %: kept. The SSE2 node test
//! compiles to ~50 instructions for eight children. The `b·inv − o·inv` form is not used
//! even at the AVX2 level, where FMA is available: every level must return bit-identical hits
//! (`simd.rs`), and SSE2 has no FMA; without FMA that form saves nothing and would need a
//! looser error bound.
//!
//! The slab test is made conservative as in Ize, "Robust BVH Ray Traversal" (JCGT 2(2), 2013):
//! the far distance is scaled by 1 + 2γ(3), which covers the rounding of `(b − o) · (1/d)`,
//! so a box test can never cull a ray that the watertight triangle test would hit. (Folding the
//! scale into the far planes' reciprocals, `inv · (1 + 2γ(3))` once per ray, and into `t_max`
//! is as conservative, four roundings either way, and saves a multiplication per node: measured
//! 0–2 % faster in `traversal_table` but 3–5 % slower end to end on the Cornell
//! box path tracer (three more per-ray registers), so not kept: `docs/perf.md`.) obvhs's own
//! CWBVH node test also clamps the entry distance to a scene-scale ε = 1e-4 (`cwbvh/node.rs`
//! `EPSILON`), which culls every box closer than 1e-4 along the ray; here entry is clamped to 0.

use rayon::prelude::*;

use crate::ray::gamma;
use crate::simd::{NodeRay, NodeTest};
use crate::triangle::NO_LANE;

/// Slots of a packet (a packed leaf has one or two); also the block the binary build's split
/// costs count triangles in (`sah.rs`).
pub(crate) const PACKET: usize = 4;

/// How many packets a packed leaf of `count` primitives has (its first is where its reference
/// starts, [`leaf_parts`]).
#[inline(always)]
pub(crate) fn packets_in(count: usize) -> usize {
    count.div_ceil(PACKET)
}

/// Ize 2013, §3: scaling the far distance by 1 + 2γ(3) covers the rounding of the slab
/// distances (one subtraction, one product with a rounded reciprocal). Evaluated at compile
/// time with the same IEEE operations as at run time, so the bits are those of the expression.
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// A collapsed tree ([`WideBvh::from_bvh2`]).
pub(crate) struct Collapsed {
    pub(crate) bvh: WideBvh,
    /// The primitives of the leaves below `packed_from`, in leaf order.
    pub(crate) singles: Vec<u32>,
    /// The packed leaves' primitives, four slots per packet and one or two packets per leaf
    /// (`NO_LANE` where unused).
    pub(crate) packed: Vec<u32>,
    /// The tree's surface-area cost, as the collapse computed it.
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) cost: f32,
}

/// Marks an empty child slot (its bounds are inverted, so it is never hit either).
const EMPTY: u32 = u32::MAX;
/// Set in a child reference that is a leaf: bits 28–30 hold count − 1, bits 0–27 where it
/// starts (its first slot, or its first packet: [`WideBvh::from_bvh2`]). (28 bits: 2²⁸ ≈ 268M
/// primitives per tree, which the loaders' charge of 256 bytes per triangle puts at a 64 GiB
/// budget; when leaves held at most four, starts had 29 bits.)
const LEAF: u32 = 1 << 31;
const LEAF_START_BITS: u32 = 28;
/// One past the largest start a leaf reference can address.
pub(crate) const MAX_PRIMITIVES: usize = 1 << LEAF_START_BITS;
/// Most primitives a leaf can hold (count − 1 in three bits). Eight rather than four (`docs/perf.md`):
/// a third fewer nodes (terrain 100k 7110 → 4864) and 3–10 % faster
/// queries in `traversal_table`, for 2–4 bytes per triangle less; every node visited is several
/// hard-to-predict branches (leaf or not, how many children), a second packet of a leaf none.
pub(crate) const MAX_LEAF: usize = 8;
const _: () = assert!(MAX_LEAF.is_power_of_two() && (((MAX_LEAF - 1) as u32) << LEAF_START_BITS) < LEAF);

/// (start, count) of a leaf reference (one with [`LEAF`] set).
#[inline(always)]
fn leaf_parts(c: u32) -> (usize, usize) {
    ((c & (MAX_PRIMITIVES as u32 - 1)) as usize, ((c >> LEAF_START_BITS) & (MAX_LEAF as u32 - 1)) as usize + 1)
}

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

/// How a binary node spends the slots of its wide parent (`SlotCosts`): `how[i − 1]` for at
/// most i slots is [`LEAF_SLOT`] (one leaf), [`NODE_SLOT`] (one wide node), [`SAME`] (as i − 1
/// slots) or the left child's share j of a split. A child is never given all eight slots (its
/// sibling takes one), so index 7 serves the node's own wide node instead: the left child's
/// share of its eight slots.
type How = [u8; 8];
const LEAF_SLOT: u8 = 0xff;
const NODE_SLOT: u8 = 0xfe;
const SAME: u8 = 0xfd;

/// Subtrees with at least this many descendants have their two children's slot costs computed
/// in parallel (rayon), down to [`SLOT_FORK_LEVELS`] levels of forks, and binary trees of this
/// many nodes are read off in parallel: below that size a fork costs more than it saves, and a
/// small scene never starts rayon's pool here.
const SLOT_PARALLEL_MIN: usize = 1 << 15;
const SLOT_FORK_LEVELS: u32 = 8;

/// The bottom-up half of [`WideBvh::from_bvh2`]: for every binary node and every number of
/// slots i = 1..8 it may fill in its wide parent, the cheapest way to spend them.
struct SlotCosts<'a, F, G> {
    bn: &'a [crate::sah::Node],
    prims: &'a [u32],
    leaf_cost: F,
    leaf_ok: G,
}

impl<F: Fn(usize) -> f32 + Sync, G: Fn(&[u32]) -> bool + Sync> SlotCosts<'_, F, G> {
    /// Node `n`'s costs for 1..8 slots, its primitive range (first, count) and its [`How`];
    /// its descendants' [`How`]s are written to `below`, which holds nodes `at`.. (`sah.rs`
    /// gives every subtree's descendants one range, the children first, side by side).
    /// Large subtrees fork; the numbers are the serial ones (each node's are computed alone).
    fn subtree(&self, n: usize, below: &mut [How], at: usize, forks: u32) -> ([f32; 8], u32, u32, How) {
        let node = &self.bn[n];
        if node.is_leaf() || below.len() < SLOT_PARALLEL_MIN || forks >= SLOT_FORK_LEVELS {
            return self.serial(n, below, at);
        }
        let (l, r) = (node.first_index() as usize, node.first_index() as usize + 1);
        debug_assert_eq!(l, at, "children first in the descendants' range");
        let (pair, rest) = below.split_at_mut(2);
        // The right child's descendants start where its children are; a leaf has none.
        let right = &self.bn[r];
        let left_len = if right.is_leaf() { rest.len() } else { right.first_index() as usize - (at + 2) };
        let (left_below, right_below) = rest.split_at_mut(left_len);
        let (left, right) = rayon::join(
            || self.subtree(l, left_below, at + 2, forks + 1),
            || self.subtree(r, right_below, at + 2 + left_len, forks + 1),
        );
        (pair[0], pair[1]) = (left.3, right.3);
        debug_assert_eq!(left.1 + left.2, right.1, "leaves out of order");
        let (cost, how) = self.node(n, left.1, left.2 + right.2, Some((&left.0, &right.0)));
        (cost, left.1, left.2 + right.2, how)
    }

    /// [`SlotCosts::subtree`] on this thread: post-order with an explicit stack (a degenerate
    /// tree is as deep as it is large). Only the subtrees whose parent is still to come keep
    /// their costs and primitive ranges (`done`: (cost, first, count)), so this takes memory in
    /// proportion to the depth; an array of them per node was 40 bytes a node, 80 a triangle,
    /// at the build's peak.
    fn serial(&self, root: usize, below: &mut [How], at: usize) -> ([f32; 8], u32, u32, How) {
        let mut root_how = [LEAF_SLOT; 8];
        let mut done: Vec<([f32; 8], u32, u32)> = Vec::new();
        let mut todo = vec![(root, false)];
        while let Some((n, children_done)) = todo.pop() {
            let node = &self.bn[n];
            let is_leaf = node.is_leaf();
            if !is_leaf && !children_done {
                let l = node.first_index() as usize;
                todo.extend([(n, true), (l + 1, false), (l, false)]);
                continue;
            }
            let (first, count, costs) = if is_leaf {
                (node.first_index(), 1, None)
            } else {
                let (right, left) = (done.pop(), done.pop());
                let (Some(left), Some(right)) = (left, right) else { unreachable!("both children are done") };
                debug_assert_eq!(left.1 + left.2, right.1, "leaves out of order");
                (left.1, left.2 + right.2, Some((left.0, right.0)))
            };
            let (cost, how) = self.node(n, first, count, costs.as_ref().map(|(l, r)| (l, r)));
            if n == root {
                root_how = how;
            } else {
                below[n - at] = how;
            }
            done.push((cost, first, count));
        }
        let Some((cost, first, count)) = done.pop() else { unreachable!("the root is done") };
        (cost, first, count, root_how)
    }

    /// Node `n`'s costs and [`How`], from its primitive range and its children's costs (`None`
    /// for a leaf of the binary tree).
    fn node(&self, n: usize, first: u32, count: u32, children: Option<(&[f32; 8], &[f32; 8])>) -> ([f32; 8], How) {
        let area = self.bn[n].aabb().half_area();
        let (first_u, count_u) = (first as usize, count as usize);
        // (Decided by `allowed`, not by an infinite cost: the costs cannot overflow at the
        // magnitudes `build_scaled` hands over, but a leaf that does not fit must never be
        // chosen even if they did.)
        let allowed = count_u <= MAX_LEAF && (self.leaf_ok)(&self.prims[first_u..first_u + count_u]);
        let leaf = if allowed { area * (self.leaf_cost)(count_u) } else { f32::INFINITY };
        let Some((cost_l, cost_r)) = children else {
            return ([leaf; 8], [LEAF_SLOT; 8]);
        };
        // split[i − 1]: i slots shared by the children, each taking at least one: the least
        // sum, the first (least j) of equal ones.
        let mut split = [(f32::INFINITY, 1u8); 8];
        if cost_l[0] == cost_l[6] {
            // The left child gains nothing from more slots (a leaf of the binary tree: the case
            // of both children in two of five nodes). A node's costs for 1..7 slots never rise,
            // so the sum is least, and first, with one slot on the left: the search below would
            // return the same, and it was most of this function's time.
            for i in 2..=8 {
                split[i - 1] = (cost_l[0] + cost_r[i - 2], 1);
            }
        } else {
            for i in 2..=8 {
                for j in 1..i {
                    let c = cost_l[j - 1] + cost_r[i - j - 1];
                    if c < split[i - 1].0 {
                        split[i - 1] = (c, j as u8);
                    }
                }
            }
        }
        let (mut cost, mut how) = ([0f32; 8], [0u8; 8]);
        let node = area + split[7].0;
        (cost[0], how[0]) = if allowed && leaf <= node { (leaf, LEAF_SLOT) } else { (node, NODE_SLOT) };
        (cost[7], how[7]) = split[7];
        for i in 2..=7 {
            (cost[i - 1], how[i - 1]) = if cost[i - 2] <= split[i - 1].0 { (cost[i - 2], SAME) } else { split[i - 1] };
        }
        (cost, how)
    }
}

impl WideBvh {
    /// Collapse `sah.rs`'s binary tree (one primitive per leaf) into eight-wide nodes by the
    /// surface-area cost of Ylitie et al. 2017 (§3.1): for every binary node and every number
    /// of slots i = 1..8 it may fill in its wide parent, the cheapest way to spend them (one
    /// leaf, one wide node, or the slots split between its two children), bottom up; then the
    /// tree is read off top down. A leaf of `count` primitives costs `area · leaf_cost(count)`
    /// (∞ where `leaf_ok` refuses the subtree's primitives), a wide node `area · 1` plus its
    /// children. Returns the tree and the primitives of its leaves in two lists: a leaf of fewer
    /// than `packed_from` primitives refers to consecutive slots of the first; a larger one to
    /// a packet of the second, its primitives padded with [`NO_LANE`] to four slots (packet =
    /// slot / 4). A leaf's count says which list it is in. `scale` multiplies every box:
    /// the factor the tree was built at (`bvh.rs` `build_scaled`), undone exactly; each box is
    /// then rounded outward by an ulp.
    pub(crate) fn from_bvh2(
        bvh2: &crate::sah::Tree,
        scale: f32,
        leaf_cost: impl Fn(usize) -> f32 + Sync,
        leaf_ok: impl Fn(&[u32]) -> bool + Sync,
        packed_from: usize,
    ) -> Collapsed {
        Self::collapse(bvh2, scale, leaf_cost, leaf_ok, packed_from, SLOT_PARALLEL_MIN)
    }

    /// [`WideBvh::from_bvh2`], its read-off in parallel for binary trees of at least
    /// `parallel_from` nodes (the same tree either way).
    fn collapse(
        bvh2: &crate::sah::Tree,
        scale: f32,
        leaf_cost: impl Fn(usize) -> f32 + Sync,
        leaf_ok: impl Fn(&[u32]) -> bool + Sync,
        packed_from: usize,
        parallel_from: usize,
    ) -> Collapsed {
        let bn = &bvh2.nodes;
        // The binary build makes one leaf per primitive; the collapse forms every larger leaf itself.
        let children = |n: usize| {
            let l = bn[n].first_index() as usize;
            (l, l + 1)
        };
        // `sah::build`'s layout: the primitives in leaf order, a leaf's `first_index` its position,
        // so a subtree's primitives are one range of them.
        let prims = &bvh2.primitive_indices[..];
        // Bottom up, every node's `How` (in parallel over large subtrees), and the root's cost.
        let mut how = vec![[0u8; 8]; bn.len()];
        let root_cost = match how.split_first_mut() {
            None => 0.0,
            Some((root_how, below)) => {
                let dp = SlotCosts { bn, prims, leaf_cost, leaf_ok };
                let (cost, _, _, root) = dp.subtree(0, below, 1, 0);
                *root_how = root;
                cost[0]
            }
        };
        // The primitive range (first, count) of a subtree the collapse made a leaf: from its
        // leftmost leaf to its rightmost (a subtree's primitives are one range, in leaf order).
        let span = |n: usize| {
            let (mut first, mut last) = (n, n);
            while !bn[first].is_leaf() {
                first = children(first).0;
            }
            while !bn[last].is_leaf() {
                last = children(last).1;
            }
            let first = bn[first].first_index();
            (first, bn[last].first_index() - first + 1)
        };
        // The slots subtree n fills with at most i < 8 of them (`todo`: scratch, left empty).
        let gather = |n: usize, i: usize, out: &mut Vec<usize>, todo: &mut Vec<(usize, usize)>| {
            todo.push((n, i));
            while let Some((n, mut i)) = todo.pop() {
                while how[n][i - 1] == SAME {
                    i -= 1;
                }
                match how[n][i - 1] {
                    LEAF_SLOT | NODE_SLOT => out.push(n),
                    j => {
                        let (l, r) = children(n);
                        let j = j as usize;
                        todo.push((r, i - j));
                        todo.push((l, j));
                    }
                }
            }
        };
        let empty = WideNode {
            bounds: [
                [f32::INFINITY; 8],
                [f32::NEG_INFINITY; 8],
                [f32::INFINITY; 8],
                [f32::NEG_INFINITY; 8],
                [f32::INFINITY; 8],
                [f32::NEG_INFINITY; 8],
            ],
            children: [EMPTY; 8],
        };
        // The wide subtree whose root `start.0` (allocated) stands for binary node `start.1`,
        // depth first, the first child's subtree next, siblings allocated side by side; with
        // `only_root`, just that node, returning its wide children still to fill (as a stack:
        // the last child first).
        let emit = |start: (usize, usize),
                    nodes: &mut Vec<WideNode>,
                    order: &mut Vec<u32>,
                    packed: &mut Vec<u32>,
                    only_root: bool|
         -> Vec<(usize, usize)> {
            // (wide node to fill, the binary node it stands for).
            let mut work = vec![start];
            let (mut slots, mut todo) = (Vec::with_capacity(8), Vec::new());
            while let Some((wide, n)) = work.pop() {
                slots.clear();
                if how[n][0] == LEAF_SLOT {
                    // Only the root of a tree of a few primitives: a wide node of that one leaf.
                    slots.push(n);
                } else {
                    let (l, r) = children(n);
                    let j = how[n][7] as usize;
                    gather(l, j, &mut slots, &mut todo);
                    gather(r, 8 - j, &mut slots, &mut todo);
                }
                let mut node = empty;
                let first_child = nodes.len();
                for (slot, &item) in slots.iter().enumerate() {
                    let aabb = bn[item].aabb();
                    for axis in 0..3 {
                        node.bounds[2 * axis][slot] = (aabb.min[axis] * scale).next_down();
                        node.bounds[2 * axis + 1][slot] = (aabb.max[axis] * scale).next_up();
                    }
                    node.children[slot] = if how[item][0] == LEAF_SLOT {
                        let (first, count) = span(item);
                        let (first, count) = (first as usize, count as usize);
                        let start = if count >= packed_from {
                            // A packet of four slots per four primitives, the unused ones `NO_LANE`.
                            let start = packed.len();
                            packed.extend_from_slice(&prims[first..first + count]);
                            packed.resize(start + PACKET * packets_in(count), NO_LANE);
                            start / PACKET
                        } else {
                            order.extend_from_slice(&prims[first..first + count]);
                            order.len() - count
                        };
                        debug_assert!((1..=MAX_LEAF).contains(&count) && start < MAX_PRIMITIVES);
                        LEAF | (((count - 1) as u32) << LEAF_START_BITS) | start as u32
                    } else {
                        nodes.push(empty);
                        (nodes.len() - 1) as u32
                    };
                }
                nodes[wide] = node;
                let pending = work.len();
                let inner = slots.iter().filter(|&&item| how[item][0] != LEAF_SLOT);
                work.extend(inner.enumerate().map(|(k, &item)| (first_child + k, item)));
                work[pending..].reverse();
                if only_root {
                    return work;
                }
            }
            work
        };
        let (mut nodes, mut order, mut packed) = (vec![empty], Vec::new(), Vec::new());
        if bn.len() < parallel_from {
            emit((0, 0), &mut nodes, &mut order, &mut packed, false);
        } else {
            // The root here, then its children's subtrees in parallel, each into lists of its
            // own (its root at 0), appended in order and renumbered: the serial layout, in which
            // the root's children sit side by side after it and each one's subtree follows the
            // one before. (Serial, this was 58 ms of the 1.6M terrain's build, mostly waiting on
            // memory.)
            let mut top = emit((0, 0), &mut nodes, &mut order, &mut packed, true);
            top.reverse();
            let parts: Vec<_> = top
                .par_iter()
                .map(|&(wide, n)| {
                    let (mut nodes, mut order, mut packed) = (vec![empty], Vec::new(), Vec::new());
                    emit((0, n), &mut nodes, &mut order, &mut packed, false);
                    (wide, nodes, order, packed)
                })
                .collect();
            // Reserved exactly: grown by doubling, the lists held up to twice their size while
            // the parts were still held too (the 1.6M terrain's peak: 139 bytes a triangle
            // against 127 reserved, 126 serial).
            nodes.reserve_exact(parts.iter().map(|p| p.1.len() - 1).sum());
            order.reserve_exact(parts.iter().map(|p| p.2.len()).sum());
            packed.reserve_exact(parts.iter().map(|p| p.3.len()).sum());
            for (wide, part_nodes, part_order, part_packed) in parts {
                // Local node k ≥ 1 is appended at nodes.len() + k − 1; leaf starts shift by the
                // slots or packets already laid out.
                let (node_base, order_base, packet_base) = (nodes.len() - 1, order.len(), packed.len() / PACKET);
                let renumber = |mut node: WideNode| {
                    for c in &mut node.children {
                        if *c == EMPTY {
                            continue;
                        }
                        *c = if *c & LEAF == 0 {
                            *c + node_base as u32
                        } else {
                            let (start, count) = leaf_parts(*c);
                            let start = start + if count >= packed_from { packet_base } else { order_base };
                            debug_assert!(start < MAX_PRIMITIVES);
                            LEAF | (((count - 1) as u32) << LEAF_START_BITS) | start as u32
                        };
                    }
                    node
                };
                nodes[wide] = renumber(part_nodes[0]);
                nodes.extend(part_nodes[1..].iter().map(|&node| renumber(node)));
                order.extend_from_slice(&part_order);
                packed.extend_from_slice(&part_packed);
            }
        }
        // Grown by pushes: without this up to half the array would be spare capacity.
        nodes.shrink_to_fit();
        Collapsed { bvh: Self { nodes }, singles: order, packed, cost: root_cost }
    }

    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Every leaf as (first slot or packet, count), in node order (for tests of the tree's shape).
    #[cfg(test)]
    pub(crate) fn leaves(&self) -> Vec<(usize, usize)> {
        let mut leaves = Vec::new();
        for node in &self.nodes {
            for &c in &node.children {
                if c != EMPTY && c & LEAF != 0 {
                    leaves.push(leaf_parts(c));
                }
            }
        }
        leaves
    }

    pub(crate) fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode>()
    }

    /// Visit the leaves a ray may hit in (0, `t_max`], nearest first when `closest`.
    /// `leaf(start, count, t_max)` tests the leaf's `count` primitives (from slot or packet
    /// `start`, as [`WideBvh::from_bvh2`] laid them out) and returns
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
        // Which of bounds[2a], bounds[2a+1] is the near plane on each axis: the reciprocal's
        // sign bit (it is never ±0 or NaN, so the bit says `r < 0`). As `usize::from(r < 0.0)`
        // some builds compiled it to three branches that the paper's scene mispredicted 0.3
        // times per ray (cachegrind); a bit cannot become a branch.
        let near = inv.map(|r| (r.to_bits() >> 31) as usize);
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
                let (start, count) = leaf_parts(current);
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
/// pathologically deep tree, so no depth limit can drop a subtree. `len` counts both parts:
/// entries from `INLINE_STACK` on live in `spill`, so a pop reads the spill only when `len`
/// says so (one compare of a register, instead of the spill's length in memory every pop).
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
        } else {
            self.spill.push(e);
        }
        self.len += 1;
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        if self.len < INLINE_STACK { Some(self.inline[self.len]) } else { self.spill.pop() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` boxes, their centres uniform in a cube of side 10, their half sizes per axis uniform
    /// in `floor`..`floor + size` where `half(i)` = (size, floor).
    fn random_boxes(seed: u64, n: usize, half: impl Fn(usize) -> (f32, f32)) -> Vec<obvhs::aabb::Aabb> {
        let mut next = crate::test_uniform(seed);
        (0..n)
            .map(|i| {
                let c = glam::Vec3A::new(next(), next(), next()) * 10.0;
                let (size, floor) = half(i);
                let h = glam::Vec3A::new(next(), next(), next()) * size + floor;
                obvhs::aabb::Aabb { min: c - h, max: c + h }
            })
            .collect()
    }

    /// A leaf's cost as `bvh.rs` costs triangles (packets from three).
    fn leaf_cost(n: usize) -> f32 {
        if n < 3 { 0.3 * n as f32 } else { 0.3 * (1.0 + 0.3 * (n as f32 - 1.0)) }
    }

    /// Half the surface area of the box of child `slot` of `node`.
    fn half_area(node: &WideNode, slot: usize) -> f32 {
        let b = &node.bounds;
        let d = [b[1][slot] - b[0][slot], b[3][slot] - b[2][slot], b[5][slot] - b[4][slot]];
        (d[0] + d[1]) * d[2] + d[0] * d[1]
    }

    #[test]
    fn the_tree_read_off_costs_what_the_collapse_computed() {
        // Random boxes through the binary build (`sah.rs`): the cost of the emitted tree (a wide node: its box's
        // half area; a leaf: its box's times the leaf cost) must be the dynamic programme's
        // optimum, and every wide node but the root must have two children or more.
        let boxes = random_boxes(99, 3000, |_| (0.2, 0.01));
        let bvh2 = crate::sah::build(&mut boxes.clone(), PACKET);
        let c = WideBvh::from_bvh2(&bvh2, 1.0, leaf_cost, |_| true, 3);
        let mut total = 0f64;
        let mut children = vec![0usize; c.bvh.nodes.len()];
        for (i, node) in c.bvh.nodes.iter().enumerate() {
            let used: Vec<usize> = (0..8).filter(|&k| node.children[k] != EMPTY).collect();
            children[i] = used.len();
            let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
            for &k in &used {
                for a in 0..3 {
                    lo[a] = lo[a].min(node.bounds[2 * a][k]);
                    hi[a] = hi[a].max(node.bounds[2 * a + 1][k]);
                }
                let r = node.children[k];
                if r & LEAF != 0 {
                    total += f64::from(half_area(node, k) * leaf_cost(leaf_parts(r).1));
                }
            }
            let d = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
            total += f64::from((d[0] + d[1]) * d[2] + d[0] * d[1]);
        }
        let relative = (total / f64::from(c.cost) - 1.0).abs();
        assert!(relative < 1e-4, "emitted {total}, computed {}", c.cost);
        assert!(children[1..].iter().all(|&n| n >= 2), "a wide node of one child");
        assert!(children[0] >= 2 && c.bvh.nodes.len() < 3000 / 4, "{} nodes", c.bvh.nodes.len());
    }

    #[test]
    fn parallel_read_off_is_the_serial_one() {
        // Boxes of mixed sizes, so that leaves of both lists occur below the root's children.
        let mut boxes = random_boxes(11, 20_000, |i| (0.02, if i % 5 == 0 { 0.3 } else { 0.01 }));
        let bvh2 = crate::sah::build(&mut boxes, PACKET);
        let serial = WideBvh::collapse(&bvh2, 1.0, leaf_cost, |_| true, 3, usize::MAX);
        let parallel = WideBvh::collapse(&bvh2, 1.0, leaf_cost, |_| true, 3, 0);
        assert!(serial.singles.len() > 1000 && serial.packed.len() > 1000);
        assert_eq!((&parallel.singles, &parallel.packed), (&serial.singles, &serial.packed));
        assert_eq!(parallel.bvh.nodes.len(), serial.bvh.nodes.len());
        for (p, s) in parallel.bvh.nodes.iter().zip(&serial.bvh.nodes) {
            assert_eq!(
                (p.children, p.bounds.map(|row| row.map(f32::to_bits))),
                (s.children, s.bounds.map(|row| row.map(f32::to_bits)))
            );
        }
    }

    #[test]
    fn slot_costs_of_a_node_are_the_searchs() {
        // `SlotCosts::node` against the plain search over every split, on children's costs as
        // the programme makes them (never rising over 1..7 slots; any cost for 8), on a coarse
        // grid so that ties are common, a third with a constant left side (its shortcut).
        let mut next = crate::test_uniform(5);
        let mut boxes = [obvhs::aabb::Aabb { min: glam::Vec3A::ZERO, max: glam::Vec3A::ONE }; 3];
        let tree = crate::sah::build(&mut boxes, 1);
        let dp = SlotCosts {
            bn: &tree.nodes,
            prims: &tree.primitive_indices,
            leaf_cost: |_: usize| 1.0,
            leaf_ok: |_: &[u32]| true,
        };
        let mut costs = |constant: bool| {
            let mut c = [0f32; 8];
            c[0] = (next() * 8.0).floor() * 0.25 + 1.0;
            for i in 1..8 {
                c[i] = if constant { c[0] } else { c[i - 1] - (next() * 3.0).floor() * 0.125 };
            }
            c[7] = next();
            c
        };
        let mut shortcuts = 0;
        for round in 0..3000 {
            let (l, r) = (costs(round % 3 == 0), costs(round % 5 == 0));
            let (cost, how) = dp.node(0, 0, 3, Some((&l, &r)));
            let mut split = [(f32::INFINITY, 1u8); 8];
            for i in 2..=8 {
                for j in 1..i {
                    let c = l[j - 1] + r[i - j - 1];
                    if c < split[i - 1].0 {
                        split[i - 1] = (c, j as u8);
                    }
                }
            }
            assert_eq!((cost[7], how[7]), split[7], "{l:?} {r:?}");
            for i in 2..=7 {
                let expected = if cost[i - 2] <= split[i - 1].0 { (cost[i - 2], SAME) } else { split[i - 1] };
                assert_eq!((cost[i - 1], how[i - 1]), expected, "{i}: {l:?} {r:?}");
            }
            shortcuts += usize::from(l[0] == l[6]);
        }
        assert!(shortcuts >= 1000, "{shortcuts}");
    }

    #[test]
    fn parallel_slot_costs_are_the_serial_ones() {
        // Enough boxes that the root's subtrees fork (2n − 2 descendants ≥ SLOT_PARALLEL_MIN),
        // and a leaf test that refuses some leaves, so that every kind of `How` occurs.
        let n = SLOT_PARALLEL_MIN / 2 + 5000;
        let mut boxes = random_boxes(7, n, |_| (0.05, 0.001));
        let bvh2 = crate::sah::build(&mut boxes, PACKET);
        let dp = SlotCosts {
            bn: &bvh2.nodes,
            prims: &bvh2.primitive_indices,
            leaf_cost: |c: usize| 0.3 * c as f32,
            leaf_ok: |p: &[u32]| p.iter().all(|&i| i % 97 != 0) || p.len() == 1,
        };
        let (mut parallel, mut serial) = (vec![[0u8; 8]; 2 * n - 1], vec![[0u8; 8]; 2 * n - 1]);
        let p = dp.subtree(0, &mut parallel[1..], 1, 0);
        let s = dp.serial(0, &mut serial[1..], 1);
        (parallel[0], serial[0]) = (p.3, s.3);
        assert_eq!((p.0.map(f32::to_bits), p.1, p.2), (s.0.map(f32::to_bits), s.1, s.2));
        assert!(parallel == serial);
        for kind in [LEAF_SLOT, NODE_SLOT, SAME] {
            assert!(serial.iter().any(|h| h.contains(&kind)), "{kind:#x}");
        }
        // The root's children took the forking path: their Hows came from the pair it writes.
        assert_ne!(serial[1], [0; 8]);
    }

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
