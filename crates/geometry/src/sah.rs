//! The binary tree that `wide.rs` collapses: a top-down binned SAH build (Wald 2007, "On fast
//! Construction of SAH-based Bounding Volume Hierarchies"; 16 centroid bins per axis), down to one
//! primitive per leaf, the collapse choosing the leaves. Split costs count primitives in blocks
//! of four, the triangle packet (`wide.rs` `PACKET`, passed in by `bvh.rs`), as Embree's builders do (its `sahBlockSize`): the sides of a
//! split tend to hold multiples of four, and the collapse finds full packets.
//!
//! obvhs built this tree before (PLOC, then reinsertion: its `medium_build` preset).
//! Measured against that (`docs/perf.md`), with the same collapse and traversal: the
//! trees' surface-area cost in Embree's units (a wide node 1, a block of four triangles 1) falls
//! from 9.20 / 13.80 / 16.55 to 6.49 / 11.18 / 13.90 on the 2k / 100k / 1M terrains (Embree's
//! own trees: 6.32 / 11.11 / 13.81), queries run 13–53 % faster, and memory falls from 57–59 to
//! 48–50 bytes per triangle. 16 bins rather than 32: queries within ±3 % (4 rounds), builds
//! 13 % faster (1M terrain 0.65 → 0.57 s on two threads, about PLOC's 0.60 s).

use glam::Vec3A;
use obvhs::aabb::Aabb;
use rayon::prelude::*;

use crate::simd::truncate_clamped;

/// Centroid bins per axis.
const BINS: usize = 16;

/// Subtrees of at least this many primitives on both sides of a split are built in parallel
/// (rayon), down to [`FORK_LEVELS`] levels of forks.
const PARALLEL_MIN: usize = 8192;
/// At most 2⁸ parallel subtrees: enough tasks for any machine, and a bounded recursion.
const FORK_LEVELS: u32 = 8;

/// The binary tree over `boxes`: node 0 the root, the children of an inner node side by side at
/// `first_index`, one primitive per leaf (`first_index` into `primitive_indices`). `block`: the
/// primitives per block of the split cost (1: every primitive its own leaf, as placements are).
///
/// `boxes` is reordered with the primitives (left in leaf order, as `primitive_indices`): every
/// pass of the build reads a node's boxes as one run of memory. Read through indices, the passes
/// over the top levels' millions of boxes were cache misses.
pub(crate) fn build(boxes: &mut [Aabb], block: usize) -> Tree {
    debug_assert!(block > 0);
    let n = boxes.len();
    // Node indices below 2³¹ (`Node::index`'s leaf bit): callers refuse more primitives.
    assert!(n <= crate::wide::MAX_PRIMITIVES, "{n} primitives");
    let mut indices: Vec<u32> = (0..n as u32).collect();
    if n == 0 {
        return Tree { nodes: Vec::new(), primitive_indices: indices };
    }
    let ctx = Context { block };
    // A binary tree of n leaves has 2n − 1 nodes; every subtree of m leaves gets its 2m − 2
    // descendants as one range, so that subtrees can be built in parallel into disjoint slices.
    // (Zeroed pages from the allocator, touched first by the threads that fill them: written
    // here, the 2n − 1 nodes took 35 ms of one thread on the 1.6M terrain.)
    let mut nodes: Vec<Node> = bytemuck::zeroed_vec(2 * n - 1);
    let (root, rest) = nodes.split_first_mut().expect("n ≥ 1");
    let bounds = bounds_of(boxes);
    build_subtree(
        &ctx,
        Task { items: &mut indices, boxes, bounds, first_prim: 0, node: root, below: rest, below_at: 1 },
        0,
    );
    Tree { nodes, primitive_indices: indices }
}

/// The binary tree [`build`] makes.
#[derive(Debug)]
pub(crate) struct Tree {
    /// Node 0 the root; the two children of an inner node side by side.
    pub(crate) nodes: Vec<Node>,
    /// The primitives in leaf order.
    pub(crate) primitive_indices: Vec<u32>,
}

/// A node of the binary tree: its box and, for an inner node, the index of its first child (the
/// second follows it); for a leaf (one primitive), its position in [`Tree::primitive_indices`].
/// 28 bytes: obvhs's `Bvh2Node` (a box of two 16-byte vectors, a count and an index) took 40,
/// and the 2n − 1 nodes were the largest part of the build's peak memory (80 bytes a primitive).
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Zeroable)]
pub(crate) struct Node {
    min: [f32; 3],
    max: [f32; 3],
    /// The first child's index, or [`LEAF`] | the leaf's position.
    index: u32,
}

const LEAF: u32 = 1 << 31;

impl Node {
    fn inner(aabb: &Aabb, first_child: usize) -> Self {
        Self { min: aabb.min.to_array(), max: aabb.max.to_array(), index: first_child as u32 }
    }

    fn leaf(aabb: &Aabb, position: usize) -> Self {
        Self { min: aabb.min.to_array(), max: aabb.max.to_array(), index: LEAF | position as u32 }
    }

    pub(crate) fn is_leaf(&self) -> bool {
        self.index & LEAF != 0
    }

    /// An inner node's first child, or a leaf's position in the primitive order.
    pub(crate) fn first_index(&self) -> u32 {
        self.index & !LEAF
    }

    /// The box (the same numbers as stored: surface areas come out as from the build's boxes).
    pub(crate) fn aabb(&self) -> Aabb {
        Aabb { min: Vec3A::from_array(self.min), max: Vec3A::from_array(self.max) }
    }
}

struct Context {
    block: usize,
}

/// A node's box and its primitives' centroid bounds `lo`..`hi`. Min and max are exact in any
/// order, so however the primitives are gathered (a pass over the node, or its parent's
/// partition) the numbers are the same.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Bounds {
    aabb: Aabb,
    lo: Vec3A,
    hi: Vec3A,
}

impl Bounds {
    const EMPTY: Self = Self { aabb: Aabb::INVALID, lo: Vec3A::INFINITY, hi: Vec3A::NEG_INFINITY };

    /// Grow by a primitive's box `b` whose centroid is `c`.
    fn add(&mut self, b: &Aabb, c: Vec3A) {
        self.aabb = self.aabb.union(b);
        self.lo = self.lo.min(c);
        self.hi = self.hi.max(c);
    }

    fn union(self, other: Self) -> Self {
        Self { aabb: self.aabb.union(&other.aabb), lo: self.lo.min(other.lo), hi: self.hi.max(other.hi) }
    }
}

/// The [`Bounds`] of `boxes`, in parallel over chunks when there are many: only the root's are
/// computed by a pass of their own; every other node's come from its parent's partition.
/// (Centroids are computed where they are needed rather than stored: 12 bytes a primitive
/// less, and read with the box they come from.)
fn bounds_of(boxes: &[Aabb]) -> Bounds {
    let one = |boxes: &[Aabb]| {
        let mut bounds = Bounds::EMPTY;
        for b in boxes {
            bounds.add(b, b.center());
        }
        bounds
    };
    if boxes.len() < PARALLEL_PASS {
        return one(boxes);
    }
    boxes.par_chunks(PARALLEL_PASS / 4).map(one).reduce(|| Bounds::EMPTY, Bounds::union)
}

/// Nodes of at least this many primitives bin (and bound) them in parallel chunks.
const PARALLEL_PASS: usize = 1 << 16;

/// A subtree to build: its primitives `items` and their `boxes` (at `first_prim` in the final
/// order) with their `bounds`, its root `node`, and the slice `below` (at index `below_at` of the
/// tree) for its other nodes.
struct Task<'a> {
    items: &'a mut [u32],
    boxes: &'a mut [Aabb],
    bounds: Bounds,
    first_prim: usize,
    node: &'a mut Node,
    below: &'a mut [Node],
    below_at: usize,
}

/// Build `task`'s subtree, iteratively (a degenerate split sequence is as deep as it is long), and
/// forking balanced splits of large subtrees while `forks` < [`FORK_LEVELS`].
fn build_subtree(ctx: &Context, task: Task, forks: u32) {
    let mut work = vec![task];
    while let Some(Task { items, boxes, bounds, first_prim, node, below, below_at }) = work.pop() {
        if let [b] = boxes {
            *node = Node::leaf(b, first_prim);
            continue;
        }
        // The bounds gathered by the parent's partition are the ones a pass would give.
        #[cfg(test)]
        assert_eq!(bounds, bounds_of(boxes));
        let (mid, left_bounds, right_bounds) = split(ctx, items, boxes, &bounds);
        *node = Node::inner(&bounds.aabb, below_at);
        let (pair, rest) = below.split_at_mut(2);
        let (left_node, right_node) = pair.split_at_mut(1);
        let (left_below, right_below) = rest.split_at_mut(2 * mid - 2);
        let (left_items, right_items) = items.split_at_mut(mid);
        let (left_boxes, right_boxes) = boxes.split_at_mut(mid);
        let right_at = below_at + 2 + left_below.len();
        let left = Task {
            node: &mut left_node[0],
            first_prim,
            below_at: below_at + 2,
            items: left_items,
            boxes: left_boxes,
            bounds: left_bounds,
            below: left_below,
        };
        let right = Task {
            node: &mut right_node[0],
            first_prim: first_prim + mid,
            below_at: right_at,
            items: right_items,
            boxes: right_boxes,
            bounds: right_bounds,
            below: right_below,
        };
        if forks < FORK_LEVELS && left.items.len().min(right.items.len()) >= PARALLEL_MIN {
            rayon::join(|| build_subtree(ctx, left, forks + 1), || build_subtree(ctx, right, forks + 1));
        } else {
            work.push(right);
            work.push(left);
        }
    }
}

/// Partition `items` (two or more) and their `boxes` alike, whose [`Bounds`] are `bounds`, at the
/// cheapest binned split and return the size of the left part (1..len) and the two parts'
/// bounds: the least `area(left)·blocks(left) + area(right)·blocks(right)` over the bin
/// boundaries of the three axes; where no axis separates the centroids, the middle by count.
fn split(ctx: &Context, items: &mut [u32], boxes: &mut [Aabb], bounds: &Bounds) -> (usize, Bounds, Bounds) {
    let len = items.len();
    let scale = bin_scale(bounds);
    let lo = bounds.lo;
    // The bins of a centroid along the three axes: the truncated bin coordinate, at most the last
    // bin (`(x as usize).min(BINS − 1)` per axis, three at once; coordinates are ≥ 0 and never
    // NaN: centroids lie in lo..hi, and the scale is finite).
    let bins = |c: Vec3A| truncate_clamped((c - lo) * scale, (BINS - 1) as f32);
    if len == 2 {
        return split_pair(items, boxes, bins);
    }
    let best = if len <= SMALL { best_split_small(ctx, boxes, bins) } else { best_split_binned(ctx, boxes, bins) };
    let Some((_, axis, left_bins)) = best else {
        let mid = len / 2;
        return (mid, bounds_of(&boxes[..mid]), bounds_of(&boxes[mid..]));
    };
    // The children's bounds are gathered here, on the way: a pass of their own over every
    // node's boxes was a third of the passes over memory at the top levels.
    //
    // A centroid is left of the split if its bin along `axis` is below `left_bins` (1..BINS − 1),
    // that is if its bin coordinate x = (c − lo)·scale is: for x ≥ 0, ⌊x⌋ < k ⇔ x < k, and
    // the clamp to the last bin and to 0 change neither side. The same x as `bins` computes (the
    // same two operations, lane or scalar), without the truncation and the lanes not needed.
    let (lo_axis, scale_axis, bound) = (lo[axis], scale[axis], left_bins as f32);
    let (mut left, mut right) = (Bounds::EMPTY, Bounds::EMPTY);
    let mut mid = 0;
    for k in 0..len {
        let b = boxes[k];
        let c = b.center();
        if (c[axis] - lo_axis) * scale_axis < bound {
            items.swap(k, mid);
            boxes.swap(k, mid);
            mid += 1;
            left.add(&b, c);
        } else {
            right.add(&b, c);
        }
    }
    debug_assert!(mid > 0 && mid < len);
    (mid, left, right)
}

/// The factor from a centroid's offset from `bounds.lo` to its bin coordinate, per axis (three
/// lanes at once: one division instead of three): `BINS / extent`, at most `f32::MAX`; 0 where
/// the extent is 0.
fn bin_scale(bounds: &Bounds) -> Vec3A {
    // An axis along which all centroids coincide gets scale 0: one bin, no split. The scale is
    // capped at f32::MAX: for an extent below 16 / f32::MAX ≈ 4.7e-38 it would be ∞, and
    // 0·∞ = NaN would put the centroids at `lo` alone in bin 0 and all others in the last: each
    // split would peel off one value, a tree as deep as the centroids are many and an O(n²)
    // build (80 000 distinct subnormal centroids: 34 s; found by review). Capped, such centroids
    // share one bin and are split in the middle by count.
    let extent = bounds.hi - bounds.lo;
    let scale = (Vec3A::splat(BINS as f32) / extent).min(Vec3A::splat(f32::MAX));
    Vec3A::select(extent.cmpgt(Vec3A::ZERO), scale, Vec3A::ZERO)
}

/// [`split`] of two primitives (two in five inner nodes of a terrain's tree), without the
/// search: either side of any split is one primitive, so every axis that separates the two bins
/// costs the same sum of two areas (`blocks(1)` = 1), the search keeps the first of them, and
/// its left side is the lower bin. Where no axis separates them, the middle by count is the
/// order they are in.
fn split_pair(items: &mut [u32], boxes: &mut [Aabb], bins: impl Fn(Vec3A) -> [u32; 3]) -> (usize, Bounds, Bounds) {
    let (a, b) = (bins(boxes[0].center()), bins(boxes[1].center()));
    if let Some(axis) = (0..3).find(|&axis| a[axis] != b[axis])
        && b[axis] < a[axis]
    {
        items.swap(0, 1);
        boxes.swap(0, 1);
    }
    (1, bounds_of(&boxes[..1]), bounds_of(&boxes[1..]))
}

/// Nodes of at most this many primitives look only at the bins their primitives occupy
/// ([`best_split_small`]) instead of sweeping all [`BINS`] of each axis: most nodes of a tree
/// with one primitive per leaf are this small, and the sweeps (two unions and an area per bin,
/// 96 of each, and 48 boxes cleared) were their main cost.
const SMALL: usize = 16;

/// The cheapest split as (cost, axis, bins left of it): the least
/// `area(left)·blocks(left) + area(right)·blocks(right)` over the bin boundaries of the three axes,
/// the first of equal costs (axes in order, boundaries from the left); `None` where no axis
/// separates the centroids.
type Best = Option<(f32, usize, usize)>;

fn best_split_binned(ctx: &Context, boxes: &[Aabb], bins: impl Fn(Vec3A) -> [u32; 3] + Sync) -> Best {
    let len = boxes.len();
    let blocks = |count: usize| count.div_ceil(ctx.block) as f32;
    // All three axes binned in one pass over the primitives (in parallel chunks for the largest
    // nodes: unions and counts are exact in any order, so the bins are the serial ones).
    type Bins = ([[Aabb; BINS]; 3], [[usize; BINS]; 3]);
    const EMPTY: Bins = ([[Aabb::INVALID; BINS]; 3], [[0; BINS]; 3]);
    let bin_items = |boxes: &[Aabb]| -> Bins {
        let (mut bin_box, mut bin_count) = EMPTY;
        for b in boxes {
            let k = bins(b.center());
            for axis in 0..3 {
                let k = k[axis] as usize;
                bin_box[axis][k] = bin_box[axis][k].union(b);
                bin_count[axis][k] += 1;
            }
        }
        (bin_box, bin_count)
    };
    let merge = |mut a: Bins, b: Bins| {
        for axis in 0..3 {
            for k in 0..BINS {
                a.0[axis][k] = a.0[axis][k].union(&b.0[axis][k]);
                a.1[axis][k] += b.1[axis][k];
            }
        }
        a
    };
    let (bin_box, bin_count) = if len < PARALLEL_PASS {
        bin_items(boxes)
    } else {
        boxes.par_chunks(PARALLEL_PASS / 4).map(bin_items).reduce(|| EMPTY, merge)
    };
    let mut best: Best = None;
    for axis in 0..3 {
        let (bin_box, bin_count) = (&bin_box[axis], &bin_count[axis]);
        // The right side's cost of every split, swept from the right; then the left side's.
        let mut right_cost = [0f32; BINS];
        let (mut acc, mut count) = (Aabb::INVALID, 0);
        for b in (1..BINS).rev() {
            acc = acc.union(&bin_box[b]);
            count += bin_count[b];
            right_cost[b] = if count > 0 { acc.half_area() * blocks(count) } else { 0.0 };
        }
        let (mut acc, mut count) = (Aabb::INVALID, 0);
        for b in 0..BINS - 1 {
            acc = acc.union(&bin_box[b]);
            count += bin_count[b];
            if count == 0 || count == len {
                continue;
            }
            let cost = acc.half_area() * blocks(count) + right_cost[b + 1];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b + 1));
            }
        }
    }
    best
}

/// [`best_split_binned`]'s result for a node of at most [`SMALL`] primitives, from the bins they
/// occupy only. The same number: between two occupied bins every boundary gives the same two
/// sides, and the binned sweep keeps the first of them (the one right of the lower bin); each
/// side's box is the union of the same boxes (exact in any order), its area and cost the same
/// expressions.
fn best_split_small(ctx: &Context, boxes: &[Aabb], bins: impl Fn(Vec3A) -> [u32; 3]) -> Best {
    let len = boxes.len();
    let blocks = |count: usize| count.div_ceil(ctx.block) as f32;
    // Per axis, each primitive's bin.
    let mut item_bins = [[0u32; SMALL]; 3];
    for (k, b) in boxes.iter().enumerate() {
        let b = bins(b.center());
        (item_bins[0][k], item_bins[1][k], item_bins[2][k]) = (b[0], b[1], b[2]);
    }
    let mut best: Best = None;
    for (axis, axis_bins) in item_bins.iter().enumerate() {
        // The primitives ordered by bin (insertion sort: at most 16).
        let mut order = [(0u32, 0u8); SMALL];
        for (k, &bin) in axis_bins[..len].iter().enumerate() {
            let entry = (bin, k as u8);
            let mut at = k;
            while at > 0 && order[at - 1].0 > entry.0 {
                order[at] = order[at - 1];
                at -= 1;
            }
            order[at] = entry;
        }
        let order = &order[..len];
        if order[0].0 == order[len - 1].0 {
            continue; // one bin: no split along this axis
        }
        // right_cost[k]: the cost of the primitives order[k..] as the right side (used at the
        // first of each bin's primitives).
        let mut right_cost = [0f32; SMALL];
        let mut acc = Aabb::INVALID;
        for k in (1..len).rev() {
            acc = acc.union(&boxes[order[k].1 as usize]);
            right_cost[k] = acc.half_area() * blocks(len - k);
        }
        let mut acc = Aabb::INVALID;
        for k in 0..len - 1 {
            acc = acc.union(&boxes[order[k].1 as usize]);
            if order[k + 1].0 == order[k].0 {
                continue; // not the last of its bin
            }
            let cost = acc.half_area() * blocks(k + 1) + right_cost[k + 1];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, order[k].0 as usize + 1));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wide::PACKET;
    use glam::Vec3A;

    fn boxes(points: &[[f32; 3]]) -> Vec<Aabb> {
        points.iter().map(|&p| Aabb { min: Vec3A::from(p) - 0.1, max: Vec3A::from(p) + 0.1 }).collect()
    }

    /// `build` of a copy of `boxes`, checking that the copy comes back in leaf order.
    fn build_of(boxes: &[Aabb], block: usize) -> Tree {
        let mut reordered = boxes.to_vec();
        let bvh = build(&mut reordered, block);
        let in_leaf_order: Vec<Aabb> = bvh.primitive_indices.iter().map(|&i| boxes[i as usize]).collect();
        assert_eq!(reordered, in_leaf_order);
        bvh
    }

    /// Every primitive in exactly one leaf, with its own box; every inner node's box the union of
    /// its children's, which sit side by side. Returns the depth (edges from the root).
    fn check(bvh: &Tree, boxes: &[Aabb]) -> usize {
        let n = boxes.len();
        assert_eq!(bvh.nodes.len(), 2 * n - 1);
        let mut seen = vec![false; n];
        let mut stack = vec![(0usize, 0usize)];
        let mut depth = 0;
        while let Some((k, d)) = stack.pop() {
            depth = depth.max(d);
            let node = &bvh.nodes[k];
            if node.is_leaf() {
                let p = bvh.primitive_indices[node.first_index() as usize] as usize;
                assert!(!seen[p], "primitive {p} in two leaves");
                assert_eq!(node.aabb(), boxes[p], "leaf of primitive {p}");
                seen[p] = true;
            } else {
                let (l, r) = (node.first_index() as usize, node.first_index() as usize + 1);
                assert!(l > k, "children after their parent");
                assert_eq!(bvh.nodes[l].aabb().union(&bvh.nodes[r].aabb()), node.aabb());
                stack.extend([(l, d + 1), (r, d + 1)]);
            }
        }
        assert!(seen.iter().all(|&s| s));
        depth
    }

    /// How many subtrees have exactly four leaves.
    fn subtrees_of_four(bvh: &Tree) -> usize {
        let mut leaves = vec![0usize; bvh.nodes.len()];
        // Children come after their parents here, so a reverse sweep sees them first.
        for k in (0..bvh.nodes.len()).rev() {
            let node = &bvh.nodes[k];
            let f = node.first_index() as usize;
            leaves[k] = if node.is_leaf() { 1 } else { leaves[f] + leaves[f + 1] };
        }
        leaves.iter().filter(|&&l| l == 4).count()
    }

    #[test]
    fn split_costs_in_blocks_of_four_make_subtrees_of_four() {
        // Twelve points in a row, one apart. Counted per primitive, halving is cheapest
        // (6 | 6, then 3 | 3: no subtree of four); counted in blocks of four, 4 | 8 costs
        // 1.32·1 + 2.92·2 = 7.16 against 6 | 6's 2.12·2·2 = 8.48 (half areas of the padded
        // boxes), and the row falls into three subtrees of four.
        // Along each axis in turn.
        for axis in 0..3 {
            let points: Vec<[f32; 3]> = (0..12)
                .map(|i| {
                    let mut p = [0.0; 3];
                    p[axis] = i as f32;
                    p
                })
                .collect();
            let b = boxes(&points);
            let blocks = build_of(&b, PACKET);
            check(&blocks, &b);
            assert_eq!(subtrees_of_four(&blocks), 3, "axis {axis}");
            let singles = build_of(&b, 1);
            check(&singles, &b);
            assert_eq!(subtrees_of_four(&singles), 0, "axis {axis}");
        }
    }

    #[test]
    fn coincident_centroids_split_by_count_and_large_inputs_build_in_parallel() {
        // One point 20 000 times: no axis separates them, so every split is the middle by count
        // (depth ⌈log₂ n⌉, not n); 20 000 > 2 · PARALLEL_MIN, so the root split forks.
        let n = 20_000;
        let same = boxes(&vec![[1.0, 2.0, 3.0]; n]);
        assert_eq!(check(&build_of(&same, PACKET), &same), 15);
        // Distinct points, in parallel: the same checks.
        let points: Vec<[f32; 3]> = (0..n).map(|i| [(i % 100) as f32, (i / 100) as f32, (i % 7) as f32]).collect();
        let distinct = boxes(&points);
        check(&build_of(&distinct, PACKET), &distinct);
    }

    #[test]
    fn centroids_a_few_subnormals_apart_split_by_count() {
        // 20 000 distinct centroids 1.4e-45 apart (points as boxes of zero size): the scale,
        // 16 / 2.8e-41, overflows f32. Uncapped, 0·∞ = NaN put the lowest alone in one bin and
        // every split peeled off one point: depth n − 1, an O(n²) build. Capped, they share one
        // bin and split by count.
        let n = 20_000;
        let b: Vec<Aabb> = (0..n)
            .map(|i| {
                let p = Vec3A::new(f32::from_bits(i as u32), 1.0, 1.0);
                Aabb { min: p, max: p }
            })
            .collect();
        let depth = check(&build_of(&b, PACKET), &b);
        assert!(depth <= 20, "depth {depth}");
    }

    #[test]
    fn small_nodes_choose_the_binned_sweeps_split() {
        // Random boxes of random sizes, 2 to 16 at a time, some on a coarse grid so that
        // centroids share bins and coordinates; both block sizes.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        for round in 0..3000 {
            let len = 2 + round % (SMALL - 1);
            let grid = round % 3 == 0;
            let boxes: Vec<Aabb> = (0..len)
                .map(|_| {
                    let mut p = Vec3A::new(next(), next(), next()) * 10.0;
                    if grid {
                        p = (p * 0.3).floor();
                    }
                    let r = Vec3A::new(next(), next(), next()) * if round % 2 == 0 { 0.1 } else { 3.0 };
                    Aabb { min: p - r, max: p + r }
                })
                .collect();
            for block in [1, PACKET] {
                let ctx = Context { block };
                let bounds = bounds_of(&boxes);
                let (lo, scale) = (bounds.lo, bin_scale(&bounds));
                let bins = |c: Vec3A| truncate_clamped((c - lo) * scale, (BINS - 1) as f32);
                let small = best_split_small(&ctx, &boxes, bins);
                let binned = best_split_binned(&ctx, &boxes, bins);
                assert_eq!(
                    small.map(|b| (b.0.to_bits(), b.1, b.2)),
                    binned.map(|b| (b.0.to_bits(), b.1, b.2)),
                    "round {round}"
                );
            }
        }
    }

    #[test]
    fn bin_scale_is_capped_and_zero_on_flat_axes() {
        let scale = |lo: f32, hi: f32| {
            let b = Bounds { aabb: Aabb::INVALID, lo: Vec3A::splat(lo), hi: Vec3A::new(hi, lo, hi) };
            let s = bin_scale(&b);
            assert_eq!(s.y, 0.0, "flat axis");
            assert_eq!(s.x.to_bits(), s.z.to_bits());
            s.x
        };
        assert_eq!(scale(1.0, 3.0), 8.0);
        assert_eq!(scale(-2.0, -2.0), 0.0);
        assert_eq!(scale(0.0, f32::from_bits(2)), f32::MAX);
        assert_eq!(scale(0.0, 1e-37), (BINS as f32 / 1e-37).min(f32::MAX));
    }

    #[test]
    fn partition_by_coordinate_is_partition_by_bin() {
        // `split` puts a centroid left where its bin coordinate x < k, for the split's first
        // right bin k; the bin itself is x truncated and clamped to 0..=BINS − 1. The same side
        // for every k, at and around every integer, below 0 (never given) and beyond the last bin.
        let mut xs = vec![0.0f32, -0.0, 1e-30, 15.999_999, 16.0, 17.5, 1e30, f32::MAX];
        for i in 0..=BINS {
            let x = i as f32;
            xs.extend([x, x.next_down(), x.next_up(), x + 0.5]);
        }
        for x in xs {
            let bin = truncate_clamped(Vec3A::splat(x), (BINS - 1) as f32)[0] as usize;
            for k in 1..BINS {
                assert_eq!(x < k as f32, bin < k, "x {x} k {k}");
            }
        }
    }

    #[test]
    fn pairs_split_as_the_search_and_partition_would() {
        // Two boxes, on a coarse grid so that centroids often share bins on some axes or
        // coincide: `split_pair`'s order must be the general search's (`best_split_small`, then
        // the partition by the chosen axis's bins; the middle by count where none separates).
        let mut uniform = crate::test_uniform(17);
        let mut next = || (uniform() * 3.0).floor();
        let ctx = Context { block: PACKET };
        let mut swapped = 0;
        for _ in 0..2000 {
            let boxes: Vec<Aabb> = (0..2)
                .map(|_| {
                    let p = Vec3A::new(next(), next(), next());
                    Aabb { min: p - Vec3A::new(0.5, next(), 0.25), max: p + 0.5 }
                })
                .collect();
            let bounds = bounds_of(&boxes);
            let (lo, scale) = (bounds.lo, bin_scale(&bounds));
            let bins = |c: Vec3A| truncate_clamped((c - lo) * scale, (BINS - 1) as f32);
            let expected = match best_split_small(&ctx, &boxes, bins) {
                Some((_, axis, left_bins)) if bins(boxes[0].center())[axis] as usize >= left_bins => [1, 0],
                _ => [0, 1],
            };
            let (mut items, mut pair) = ([0u32, 1], boxes.clone());
            let (mid, left, right) = split_pair(&mut items, &mut pair, bins);
            assert_eq!((mid, items), (1, expected), "{boxes:?}");
            assert_eq!((left, right), (bounds_of(&pair[..1]), bounds_of(&pair[1..])));
            swapped += usize::from(expected == [1, 0]);
        }
        // Both orders occur.
        assert!((200..1800).contains(&swapped), "{swapped}");
    }

    #[test]
    fn parallel_passes_give_the_serial_bins_and_bounds() {
        let n = 3 * PARALLEL_PASS + 17;
        let points: Vec<[f32; 3]> =
            (0..n).map(|i| [(i % 1000) as f32 * 0.37, (i / 1000) as f32, ((i * 7919) % 113) as f32]).collect();
        let b = boxes(&points);
        let ctx = Context { block: PACKET };
        let items: Vec<u32> = (0..n as u32).rev().collect();
        let item_boxes: Vec<Aabb> = items.iter().map(|&i| b[i as usize]).collect();
        let serial = |boxes: &[Aabb]| boxes.chunks(PARALLEL_PASS - 1).fold(Bounds::EMPTY, |a, c| a.union(bounds_of(c)));
        let bounds = bounds_of(&item_boxes);
        assert_eq!(bounds, serial(&item_boxes));
        let Bounds { lo, hi, .. } = bounds;
        let scale = Vec3A::splat(16.0) / (hi - lo);
        let bins = |c: Vec3A| truncate_clamped((c - lo) * scale, (BINS - 1) as f32);
        let parallel = best_split_binned(&ctx, &item_boxes, bins);
        // The same items in pieces below the parallel size, binned serially and merged by hand.
        let mut expected: Best = None;
        let (mut bin_box, mut bin_count) = ([[Aabb::INVALID; BINS]; 3], [[0usize; BINS]; 3]);
        for &i in &items {
            let k = bins(b[i as usize].center());
            for axis in 0..3 {
                bin_box[axis][k[axis] as usize] = bin_box[axis][k[axis] as usize].union(&b[i as usize]);
                bin_count[axis][k[axis] as usize] += 1;
            }
        }
        for axis in 0..3 {
            for split in 1..BINS {
                let side = |r: std::ops::Range<usize>| {
                    let count: usize = bin_count[axis][r.clone()].iter().sum();
                    let area = bin_box[axis][r].iter().fold(Aabb::INVALID, |a, b| a.union(b)).half_area();
                    (count, area * count.div_ceil(PACKET) as f32)
                };
                let ((l, lc), (r, rc)) = (side(0..split), side(split..BINS));
                if l > 0 && r > 0 && expected.is_none_or(|(c, _, _)| lc + rc < c) {
                    expected = Some((lc + rc, axis, split));
                }
            }
        }
        assert_eq!(parallel.map(|p| (p.1, p.2)), expected.map(|e| (e.1, e.2)));
        check(&build_of(&b, PACKET), &b);
    }

    #[test]
    fn one_and_two_primitives() {
        let one = boxes(&[[0.0; 3]]);
        assert_eq!(check(&build_of(&one, PACKET), &one), 0);
        let two = boxes(&[[0.0; 3], [5.0, 0.0, 0.0]]);
        assert_eq!(check(&build_of(&two, 1), &two), 1);
        assert!(build_of(&[], PACKET).nodes.is_empty());
    }
}
