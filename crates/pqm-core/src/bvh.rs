//! Bounding volume hierarchy over triangles, for exact closest-point queries.
//!
//! [`Bvh::build`] takes vertex positions and triangles (vertex index triples)
//! and builds a binary tree of axis-aligned boxes with a binned surface area
//! heuristic (16 bins along the box's longest centroid axis; a node becomes a
//! leaf when it holds at most 2 triangles, or at most 8 triangles and no split
//! is cheaper than testing them all). Below depth 48 the builder switches to
//! median splits so the depth stays below 48 + log2(n) even for pathological
//! inputs. Subtrees of more than 8192 triangles are built in parallel with
//! rayon. The tree is flattened into one array of 64-byte nodes in depth-first
//! order, each node holding the `f32` boxes of its two children (so one cache
//! line decides which children to visit; see `Node`), and the triangles'
//! corner positions are copied in leaf order so a query touches contiguous
//! memory.
//!
//! [`Bvh::closest_point`] returns the exact closest point on the union of the
//! triangles (Ericson, *Real-Time Collision Detection*, §5.1.5, with a
//! segment fallback for degenerate triangles), the index of the triangle it
//! lies on (into the `triangles` slice given to `build`) and the squared
//! distance. The traversal visits the nearer child first and prunes boxes that
//! are farther than the best distance found (conservatively: `f32` boxes are
//! padded and rounded outwards, so pruning never loses the true answer);
//! [`Bvh::closest_point_hinted`] starts from a guess (typically the previous
//! answer for a nearby point).
//!
//! All coordinates are `f64`, in the units of the input positions. Queries are
//! `&self` and thread-safe.

use glam::DVec3;

/// Why a BVH cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BvhError {
    /// A triangle indexes past the end of the positions.
    #[error(
        "triangle {triangle} references vertex {vertex}, but there are only {count} positions"
    )]
    IndexOutOfRange {
        /// Triangle index.
        triangle: usize,
        /// The offending vertex index.
        vertex: u32,
        /// Number of positions.
        count: usize,
    },
    /// A triangle's vertex has a NaN or infinite coordinate.
    #[error("triangle {triangle} uses vertex {vertex}, which has a non-finite coordinate")]
    NonFinite {
        /// Triangle index.
        triangle: usize,
        /// The offending vertex index.
        vertex: u32,
    },
    /// More triangles than 32-bit node links can address.
    #[error("{0} triangles are too many for the BVH (at most 2^31)")]
    TooManyTriangles(usize),
}

/// Node of the temporary build tree (each node has its own box). Interior
/// nodes (`count == 0`) have their left child right after them and their right
/// child `right` entries after them (relative, so subtrees built in parallel
/// concatenate without fix-ups); leaves hold the triangles `first .. first + count`.
#[derive(Clone, Copy, Debug)]
struct BuildNode {
    bounds: Aabb,
    right: u32,
    first: u32,
    count: u32,
}

/// A flattened node, holding the boxes of its two children so one cache line
/// (64 bytes) decides which children to visit. Child `k` is a leaf with the
/// triangles `link[k] .. link[k] + count[k]` when `count[k] > 0`, an interior
/// node at index `link[k]` otherwise, or absent when `link[k] == u32::MAX`.
/// Boxes are `f32`, relative to [`Bvh::origin`], rounded outwards and padded
/// so that box distances can only be underestimated (see [`Bvh::search`]).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    lo: [[f32; 3]; 2],
    hi: [[f32; 3]; 2],
    link: [u32; 2],
    count: [u32; 2],
}

/// Triangle BVH for closest-point queries (see the module documentation).
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Centre of the scene box; node boxes are stored relative to it.
    origin: DVec3,
    /// Corner positions of the triangles, in leaf order.
    corners: Vec<[DVec3; 3]>,
    /// `original[i]` = index (into the build input) of leaf-ordered triangle `i`.
    original: Vec<u32>,
    /// `slot[t]` = leaf-order position of input triangle `t`.
    slot: Vec<u32>,
    /// Bounds of all triangles (exact, `f64`).
    bounds: Option<(DVec3, DVec3)>,
}

const BINS: usize = 16;
const MAX_SAH_DEPTH: usize = 48;
/// Fixed traversal stack: the depth bound above plus 32 median levels, with margin.
const STACK: usize = 128;
/// Subtrees with more triangles than this are built in parallel (rayon::join).
const PARALLEL_BUILD: usize = 8192;
/// Relative safety factor on `f32` box distances (see [`Bvh::search`]).
const PRUNE_FACTOR: f64 = 1.0 - 1e-5;

#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: DVec3,
    hi: DVec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: DVec3::splat(f64::INFINITY),
        hi: DVec3::splat(f64::NEG_INFINITY),
    };
    fn grow(&mut self, other: &Aabb) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
    }
    fn grow_point(&mut self, p: DVec3) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
    fn half_area(&self) -> f64 {
        let d = (self.hi - self.lo).max(DVec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

struct Builder<'a> {
    boxes: &'a [Aabb],
    centroids: &'a [DVec3],
}

impl Builder<'_> {
    /// Builds the subtree over `items` (triangle indices, reordered in place)
    /// and appends its nodes to `out`; `offset` is the position of `items[0]`
    /// in the final leaf order.
    fn build(&self, items: &mut [u32], offset: usize, depth: usize, out: &mut Vec<BuildNode>) {
        let mut bounds = Aabb::EMPTY;
        let mut cbounds = Aabb::EMPTY;
        for &t in items.iter() {
            bounds.grow(&self.boxes[t as usize]);
            cbounds.grow_point(self.centroids[t as usize]);
        }
        let index = out.len();
        out.push(BuildNode {
            bounds,
            right: 0,
            first: offset as u32,
            count: items.len() as u32,
        });
        let Some(mid) = self.split(items, depth, &bounds, &cbounds) else {
            return;
        };
        out[index].count = 0;
        let (left, right) = items.split_at_mut(mid);
        if items_len(left, right) > PARALLEL_BUILD {
            let (mut l, mut r) = (Vec::new(), Vec::new());
            rayon::join(
                || self.build(left, offset, depth + 1, &mut l),
                || self.build(right, offset + mid, depth + 1, &mut r),
            );
            out[index].right = (l.len() + 1) as u32;
            out.extend_from_slice(&l);
            out.extend_from_slice(&r);
        } else {
            self.build(left, offset, depth + 1, out);
            out[index].right = (out.len() - index) as u32;
            self.build(right, offset + mid, depth + 1, out);
        }
    }

    /// Where to split `items` (after partitioning them), or `None` for a leaf.
    fn split(&self, items: &mut [u32], depth: usize, bounds: &Aabb, cb: &Aabb) -> Option<usize> {
        let n = items.len();
        if n <= 2 {
            return None;
        }
        let extent = cb.hi - cb.lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        if extent[axis] <= 0.0 {
            // All centroids coincide: any split is as good as another. Leaves
            // stay at most 8 triangles.
            return (n > 8).then_some(n / 2);
        }
        if depth >= MAX_SAH_DEPTH {
            return Some(self.median_split(items, axis));
        }
        self.sah_split(items, axis, cb.lo[axis], extent[axis], bounds)
    }

    fn median_split(&self, items: &mut [u32], axis: usize) -> usize {
        let mid = items.len() / 2;
        let c = self.centroids;
        items.select_nth_unstable_by(mid, |&a, &b| {
            c[a as usize][axis].total_cmp(&c[b as usize][axis])
        });
        mid
    }

    /// Binned SAH along `axis`. Returns the split position after partitioning
    /// `items`, or `None` when keeping a leaf is cheaper (only for `n <= 8`).
    fn sah_split(
        &self,
        items: &mut [u32],
        axis: usize,
        lo: f64,
        extent: f64,
        bounds: &Aabb,
    ) -> Option<usize> {
        let scale = BINS as f64 / extent;
        let bin_of = |t: u32| -> usize {
            let b = ((self.centroids[t as usize][axis] - lo) * scale) as usize;
            b.min(BINS - 1)
        };
        let mut bin_box = [Aabb::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for &t in items.iter() {
            let b = bin_of(t);
            bin_box[b].grow(&self.boxes[t as usize]);
            bin_count[b] += 1;
        }
        // Sweep from the right to get the area/count of every right part.
        let mut right_area = [0.0f64; BINS];
        let mut right_count = [0usize; BINS];
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0;
        for b in (1..BINS).rev() {
            acc.grow(&bin_box[b]);
            cnt += bin_count[b];
            right_area[b] = acc.half_area();
            right_count[b] = cnt;
        }
        let mut best = (f64::INFINITY, 0usize);
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0;
        for b in 1..BINS {
            acc.grow(&bin_box[b - 1]);
            cnt += bin_count[b - 1];
            if cnt == 0 || right_count[b] == 0 {
                continue;
            }
            let cost = acc.half_area() * cnt as f64 + right_area[b] * right_count[b] as f64;
            if cost < best.0 {
                best = (cost, b);
            }
        }
        let n = items.len();
        if best.0.is_infinite() {
            return Some(self.median_split(items, axis));
        }
        // Cost model: one traversal step costs one triangle test.
        let parent = bounds.half_area().max(f64::MIN_POSITIVE);
        if n <= 8 && 1.0 + best.0 / parent >= n as f64 {
            return None;
        }
        let split_bin = best.1;
        let (mut i, mut j) = (0, n);
        while i < j {
            if bin_of(items[i]) < split_bin {
                i += 1;
            } else {
                j -= 1;
                items.swap(i, j);
            }
        }
        Some(i)
    }
}

fn items_len(a: &[u32], b: &[u32]) -> usize {
    a.len() + b.len()
}

impl Bvh {
    /// Builds the BVH of `triangles` (vertex index triples into `positions`).
    ///
    /// Degenerate triangles (repeated or collinear corners) are accepted. Fails
    /// with a [`BvhError`] when an index is out of range or a used position is
    /// not finite. An empty triangle list gives an empty BVH whose queries
    /// return `None`. Large inputs are built in parallel (rayon).
    pub fn build(positions: &[DVec3], triangles: &[[u32; 3]]) -> Result<Bvh, BvhError> {
        if triangles.len() > (1usize << 31) {
            return Err(BvhError::TooManyTriangles(triangles.len()));
        }
        let mut tri_corners = Vec::with_capacity(triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            let mut c = [DVec3::ZERO; 3];
            for (k, &v) in tri.iter().enumerate() {
                let p = *positions.get(v as usize).ok_or(BvhError::IndexOutOfRange {
                    triangle: t,
                    vertex: v,
                    count: positions.len(),
                })?;
                if !p.is_finite() {
                    return Err(BvhError::NonFinite {
                        triangle: t,
                        vertex: v,
                    });
                }
                c[k] = p;
            }
            tri_corners.push(c);
        }
        let boxes: Vec<Aabb> = tri_corners
            .iter()
            .map(|c| Aabb {
                lo: c[0].min(c[1]).min(c[2]),
                hi: c[0].max(c[1]).max(c[2]),
            })
            .collect();
        let centroids: Vec<DVec3> = boxes.iter().map(|b| (b.lo + b.hi) * 0.5).collect();
        let mut items: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut tree = Vec::with_capacity(2 * triangles.len());
        if !items.is_empty() {
            Builder {
                boxes: &boxes,
                centroids: &centroids,
            }
            .build(&mut items, 0, 0, &mut tree);
        }
        let bounds = tree.first().map(|n| (n.bounds.lo, n.bounds.hi));
        let (origin, nodes) = flatten(&tree);
        let corners: Vec<[DVec3; 3]> = items.iter().map(|&t| tri_corners[t as usize]).collect();
        let mut slot = vec![0u32; triangles.len()];
        for (i, &t) in items.iter().enumerate() {
            slot[t as usize] = i as u32;
        }
        Ok(Bvh {
            nodes,
            origin,
            corners,
            original: items,
            slot,
            bounds,
        })
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.corners.len()
    }

    /// True when the BVH holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    /// Bounding box `(min, max)` of all triangles; `None` when empty.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        self.bounds
    }

    /// Closest point to `p` on the triangles: `(point, triangle index, squared
    /// distance)`, the triangle index being into the slice given to
    /// [`Bvh::build`]. `None` only when the BVH is empty or `p` is not finite.
    pub fn closest_point(&self, p: DVec3) -> Option<(DVec3, usize, f64)> {
        self.search(p, None)
            .map(|(q, s, d2)| (q, self.original[s as usize] as usize, d2))
    }

    /// Like [`Bvh::closest_point`], but first measures the distance to
    /// triangle `hint` (an index into the build input, typically the answer
    /// for a nearby point) so the traversal can prune from the start. The
    /// result is the same as without a hint (up to ties); an out-of-range hint
    /// is ignored.
    pub fn closest_point_hinted(&self, p: DVec3, hint: usize) -> Option<(DVec3, usize, f64)> {
        let slot = self.slot.get(hint).copied();
        self.search(p, slot)
            .map(|(q, s, d2)| (q, self.original[s as usize] as usize, d2))
    }

    /// The query, working with leaf-order slots (the Hausdorff sampler carries
    /// hints as slots to avoid translating indices).
    ///
    /// Pruning uses `f32` box distances computed from `p − origin` rounded to
    /// `f32`. Boxes were padded by `1e-6 ×` the scene's half-diagonal before
    /// rounding outwards, which covers the rounding of `p` for points within
    /// twice that distance of the origin; farther points have box distances
    /// large enough for the relative factor `PRUNE_FACTOR` to cover it. A box
    /// is skipped only when its distance provably exceeds the best so far, so
    /// the answer is exact (up to `f64` rounding in the triangle test).
    pub(crate) fn search(&self, p: DVec3, hint_slot: Option<u32>) -> Option<(DVec3, u32, f64)> {
        if self.nodes.is_empty() || !p.is_finite() {
            return None;
        }
        // (closest point, slot, squared distance) so far.
        let mut best = (DVec3::ZERO, 0u32, f64::INFINITY);
        if let Some(s) = hint_slot.filter(|&s| (s as usize) < self.corners.len()) {
            self.test_leaf(p, s, 1, &mut best);
        }
        let rel = p - self.origin;
        let q32 = [rel.x as f32, rel.y as f32, rel.z as f32];
        let mut stack = [(0u32, 0.0f64); STACK];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let d0 = box_distance_squared(q32, &n.lo[0], &n.hi[0]) as f64 * PRUNE_FACTOR;
            let d1 = box_distance_squared(q32, &n.lo[1], &n.hi[1]) as f64 * PRUNE_FACTOR;
            let (near, dn, far, df) = if d0 <= d1 {
                (0, d0, 1, d1)
            } else {
                (1, d1, 0, d0)
            };
            // Strict comparisons: a box no closer than the best cannot improve it
            // (and the absent child's infinite distance is never visited).
            let mut next = None;
            if dn < best.2 {
                if n.count[near] > 0 {
                    self.test_leaf(p, n.link[near], n.count[near], &mut best);
                } else {
                    next = Some(n.link[near]);
                }
            }
            if df < best.2 {
                if n.count[far] > 0 {
                    self.test_leaf(p, n.link[far], n.count[far], &mut best);
                } else if next.is_none() {
                    next = Some(n.link[far]);
                } else if sp < STACK {
                    stack[sp] = (n.link[far], df);
                    sp += 1;
                }
            }
            if let Some(m) = next {
                node = m;
                continue;
            }
            // Pop the next subtree that can still hold something closer.
            loop {
                if sp == 0 {
                    return Some(best);
                }
                sp -= 1;
                let (m, d) = stack[sp];
                if d < best.2 {
                    node = m;
                    break;
                }
            }
        }
    }

    /// Appends to `out` the leaf-order slots of the triangles whose boxes lie
    /// within `radius` of the box `[lo, hi]` (conservatively: a few slightly
    /// farther ones may be included, none within `radius` is missed). Stops and
    /// returns `false` as soon as more than `limit` slots would be appended.
    pub(crate) fn collect_near_box(
        &self,
        lo: DVec3,
        hi: DVec3,
        radius: f64,
        limit: usize,
        out: &mut Vec<u32>,
    ) -> bool {
        if self.nodes.is_empty() {
            return true;
        }
        let (qlo, qhi) = (round_down(lo - self.origin), round_up(hi - self.origin));
        let r2 = radius * radius;
        let start = out.len();
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let mut next = None;
            for k in 0..2 {
                let d2 = box_box_distance_squared(&qlo, &qhi, &n.lo[k], &n.hi[k]) as f64;
                if d2 * PRUNE_FACTOR > r2 || n.link[k] == u32::MAX {
                    continue;
                }
                if n.count[k] > 0 {
                    if out.len() - start + n.count[k] as usize > limit {
                        return false;
                    }
                    out.extend(n.link[k]..n.link[k] + n.count[k]);
                } else if next.is_none() {
                    next = Some(n.link[k]);
                } else if sp < STACK {
                    stack[sp] = n.link[k];
                    sp += 1;
                }
            }
            match next {
                Some(m) => node = m,
                None if sp > 0 => {
                    sp -= 1;
                    node = stack[sp];
                }
                None => return true,
            }
        }
    }

    /// Corner positions of the triangle at leaf-order `slot`.
    #[inline]
    pub(crate) fn slot_corners(&self, slot: u32) -> [DVec3; 3] {
        self.corners[slot as usize]
    }

    /// Tests the leaf-ordered triangles `first .. first + count` against `best`.
    #[inline(always)]
    fn test_leaf(&self, p: DVec3, first: u32, count: u32, best: &mut (DVec3, u32, f64)) {
        for s in first..first + count {
            let [a, b, c] = self.corners[s as usize];
            let q = closest_point_on_triangle(p, a, b, c);
            let d2 = (p - q).length_squared();
            if d2 < best.2 {
                *best = (q, s, d2);
            }
        }
    }
}

/// Converts the build tree into the child-box layout (see [`Node`]).
fn flatten(tree: &[BuildNode]) -> (DVec3, Vec<Node>) {
    let Some(root) = tree.first() else {
        return (DVec3::ZERO, Vec::new());
    };
    let origin = (root.bounds.lo + root.bounds.hi) * 0.5;
    let pad = 1e-6 * (root.bounds.hi - root.bounds.lo).length() * 0.5;
    let to_f32 = |b: &Aabb| -> ([f32; 3], [f32; 3]) {
        let lo = b.lo - origin - DVec3::splat(pad);
        let hi = b.hi - origin + DVec3::splat(pad);
        (round_down(lo), round_up(hi))
    };
    // New index of every interior build node (depth-first order is kept).
    let mut new_index = vec![u32::MAX; tree.len()];
    let mut count = 0u32;
    for (i, n) in tree.iter().enumerate() {
        if n.count == 0 {
            new_index[i] = count;
            count += 1;
        }
    }
    let empty = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    let child = |i: usize| -> ([f32; 3], [f32; 3], u32, u32) {
        let n = &tree[i];
        let (lo, hi) = to_f32(&n.bounds);
        if n.count > 0 {
            (lo, hi, n.first, n.count)
        } else {
            (lo, hi, new_index[i], 0)
        }
    };
    let mut nodes = Vec::with_capacity(count.max(1) as usize);
    if root.count > 0 {
        // A single leaf: one node whose second child is absent.
        let (lo, hi, link, cnt) = child(0);
        nodes.push(Node {
            lo: [lo, empty.0],
            hi: [hi, empty.1],
            link: [link, u32::MAX],
            count: [cnt, 0],
        });
        return (origin, nodes);
    }
    for (i, n) in tree.iter().enumerate() {
        if n.count == 0 {
            let (lo0, hi0, l0, c0) = child(i + 1);
            let (lo1, hi1, l1, c1) = child(i + n.right as usize);
            nodes.push(Node {
                lo: [lo0, lo1],
                hi: [hi0, hi1],
                link: [l0, l1],
                count: [c0, c1],
            });
        }
    }
    (origin, nodes)
}

/// Componentwise `f32` not above `v` (the cast rounds to nearest; step one ulp down if needed).
fn round_down(v: DVec3) -> [f32; 3] {
    v.to_array().map(|x| {
        let y = x as f32;
        if (y as f64) > x {
            next_toward_neg(y)
        } else {
            y
        }
    })
}

/// Componentwise `f32` not below `v`.
fn round_up(v: DVec3) -> [f32; 3] {
    v.to_array().map(|x| {
        let y = x as f32;
        if (y as f64) < x {
            -next_toward_neg(-y)
        } else {
            y
        }
    })
}

/// The largest `f32` below `y` (finite, non-NaN `y`).
fn next_toward_neg(y: f32) -> f32 {
    if y == 0.0 {
        -f32::from_bits(1)
    } else if y > 0.0 {
        f32::from_bits(y.to_bits() - 1)
    } else {
        f32::from_bits(y.to_bits() + 1)
    }
}

/// Squared distance from `p` to the box `[lo, hi]` (0 inside; +∞ for the
/// empty box of an absent child).
#[inline(always)]
fn box_distance_squared(p: [f32; 3], lo: &[f32; 3], hi: &[f32; 3]) -> f32 {
    let dx = (lo[0] - p[0]).max(p[0] - hi[0]).max(0.0);
    let dy = (lo[1] - p[1]).max(p[1] - hi[1]).max(0.0);
    let dz = (lo[2] - p[2]).max(p[2] - hi[2]).max(0.0);
    dx * dx + dy * dy + dz * dz
}

/// Squared distance between the boxes `[alo, ahi]` and `[blo, bhi]` (0 when
/// they overlap; +∞ when one is the empty box).
#[inline(always)]
fn box_box_distance_squared(alo: &[f32; 3], ahi: &[f32; 3], blo: &[f32; 3], bhi: &[f32; 3]) -> f32 {
    let mut d2 = 0.0;
    for k in 0..3 {
        let gap = (blo[k] - ahi[k]).max(alo[k] - bhi[k]).max(0.0);
        d2 += gap * gap;
    }
    d2
}

/// Closest point to `p` on triangle `abc` (Ericson, *Real-Time Collision
/// Detection*, §5.1.5: Voronoi regions of vertices, then edges, then the
/// interior). Triangles whose corners are (nearly) collinear — `|ab × ac|²`
/// below `1e-24 |ab|² |ac|²`, i.e. a smallest angle under about 1e-12 rad —
/// have no well-defined interior; for them the closest point on the three
/// edges is returned instead, which is exact for a degenerate triangle.
#[inline]
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let den = d1 - d3; // = |ab|², zero only when a == b
        if den > 0.0 {
            return a + ab * (d1 / den);
        }
        return closest_point_on_degenerate(p, a, b, c);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let den = d2 - d6; // = |ac|²
        if den > 0.0 {
            return a + ac * (d2 / den);
        }
        return closest_point_on_degenerate(p, a, b, c);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let den = (d4 - d3) + (d5 - d6); // = |bc|²
        if den > 0.0 {
            return b + (c - b) * ((d4 - d3) / den);
        }
        return closest_point_on_degenerate(p, a, b, c);
    }
    // Interior: va + vb + vc = |ab × ac|² (Lagrange's identity).
    let sum = va + vb + vc;
    if sum.is_nan() || sum <= 1e-24 * ab.length_squared() * ac.length_squared() {
        return closest_point_on_degenerate(p, a, b, c);
    }
    let inv = 1.0 / sum;
    a + ab * (vb * inv) + ac * (vc * inv)
}

/// Closest point on the three edges of a degenerate triangle.
#[cold]
fn closest_point_on_degenerate(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let candidates = [
        segment_closest(p, a, b),
        segment_closest(p, b, c),
        segment_closest(p, c, a),
    ];
    let mut best = candidates[0];
    for q in &candidates[1..] {
        if (p - *q).length_squared() < (p - best).length_squared() {
            best = *q;
        }
    }
    best
}

/// The point of segment `a–b` closest to `p` (`a` when the segment is a point).
pub(crate) fn segment_closest(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 <= 0.0 {
        return a;
    }
    a + ab * ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collect_near_box_finds_every_close_triangle() {
        let mut state = 7u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let positions: Vec<DVec3> = (0..600)
            .map(|_| DVec3::new(rnd() * 10.0, rnd() * 10.0, rnd()))
            .collect();
        let tris: Vec<[u32; 3]> = (0..400)
            .map(|i| {
                let a = (i % 600) as u32;
                [
                    a,
                    (a + 1 + (rnd() * 5.0) as u32) % 600,
                    (a + 2 + (rnd() * 5.0) as u32) % 600,
                ]
            })
            .collect();
        let bvh = Bvh::build(&positions, &tris).unwrap();
        for _ in 0..200 {
            let lo = DVec3::new(rnd() * 10.0, rnd() * 10.0, rnd());
            let hi = lo + DVec3::new(rnd(), rnd(), rnd()) * 0.5;
            let radius = rnd() * 2.0;
            let mut got = Vec::new();
            assert!(bvh.collect_near_box(lo, hi, radius, usize::MAX, &mut got));
            let got: std::collections::HashSet<usize> = got
                .iter()
                .map(|&s| bvh.original[s as usize] as usize)
                .collect();
            for (t, tri) in tris.iter().enumerate() {
                let c = tri.map(|v| positions[v as usize]);
                let (tlo, thi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
                let gap = (tlo - hi).max(lo - thi).max(DVec3::ZERO).length();
                if gap <= radius {
                    assert!(got.contains(&t), "triangle {t} at {gap} <= {radius} missed");
                }
            }
            // The limit aborts.
            let mut few = Vec::new();
            if got.len() > 1 {
                assert!(!bvh.collect_near_box(lo, hi, radius, got.len() - 1, &mut few));
            }
        }
    }
}
