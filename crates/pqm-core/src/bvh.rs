//! Bounding volume hierarchy over triangles, for exact closest-point queries.
//!
//! [`Bvh::build`] takes vertex positions and triangles (vertex index triples)
//! and builds a binary tree of axis-aligned boxes with a binned surface area
//! heuristic (16 bins along the box's longest centroid axis; a node becomes a
//! leaf when it holds at most 2 triangles, or at most 8 triangles and no split
//! is cheaper than testing them all). Below depth 48 the builder switches to
//! median splits so the depth stays below 48 + log2(n) even for pathological
//! inputs. The tree is flattened into one array in depth-first order (left
//! child right after its parent), and the triangles' corner positions are
//! copied in leaf order so a query touches contiguous memory.
//!
//! [`Bvh::closest_point`] returns the exact closest point on the union of the
//! triangles (Ericson, *Real-Time Collision Detection*, §5.1.5, with a
//! segment fallback for degenerate triangles), the index of the triangle it
//! lies on (into the `triangles` slice given to `build`) and the squared
//! distance. The traversal visits the nearer child first and prunes boxes that
//! are farther than the best distance found; [`Bvh::closest_point_hinted`]
//! starts from a guess (typically the previous answer for a nearby point),
//! which makes coherent query streams much faster.
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

/// One flattened node. Interior nodes (`count == 0`) have their left child at
/// `index + 1` and their right child at `first`; leaves hold the triangles
/// `first .. first + count` of the leaf-ordered arrays.
#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    first: u32,
    count: u32,
}

/// Triangle BVH for closest-point queries (see the module documentation).
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Corner positions of the triangles, in leaf order.
    corners: Vec<[DVec3; 3]>,
    /// `original[i]` = index (into the build input) of leaf-ordered triangle `i`.
    original: Vec<u32>,
    /// `slot[t]` = leaf-order position of input triangle `t`.
    slot: Vec<u32>,
}

const BINS: usize = 16;
const MAX_SAH_DEPTH: usize = 48;
/// Fixed traversal stack: the depth bound above plus 32 median levels, with margin.
const STACK: usize = 128;

#[derive(Clone, Copy)]
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
    nodes: Vec<Node>,
}

impl Builder<'_> {
    /// Builds the subtree over `items` (triangle indices, reordered in place);
    /// `offset` is the position of `items[0]` in the final leaf order.
    fn build(&mut self, items: &mut [u32], offset: usize, depth: usize) {
        let mut bounds = Aabb::EMPTY;
        let mut cbounds = Aabb::EMPTY;
        for &t in items.iter() {
            bounds.grow(&self.boxes[t as usize]);
            cbounds.grow_point(self.centroids[t as usize]);
        }
        let index = self.nodes.len();
        self.nodes.push(Node {
            lo: bounds.lo,
            hi: bounds.hi,
            first: offset as u32,
            count: 0,
        });
        let n = items.len();
        if n <= 2 {
            self.nodes[index].count = n as u32;
            return;
        }
        let extent = cbounds.hi - cbounds.lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = if extent[axis] <= 0.0 {
            // All centroids coincide: any split is as good as another.
            if n <= 8 {
                self.nodes[index].count = n as u32;
                return;
            }
            n / 2
        } else if depth >= MAX_SAH_DEPTH {
            self.median_split(items, axis)
        } else {
            match self.sah_split(items, axis, cbounds.lo[axis], extent[axis], &bounds) {
                Some(mid) => mid,
                None => {
                    // A leaf is cheaper; only accepted for small sets (see `sah_split`).
                    self.nodes[index].count = n as u32;
                    return;
                }
            }
        };
        let (left, right) = items.split_at_mut(mid);
        self.build(left, offset, depth + 1);
        self.nodes[index].first = self.nodes.len() as u32;
        self.build(right, offset + mid, depth + 1);
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
        // Cost model: traversal step = 1 triangle test, costs relative to the parent area.
        let parent = bounds.half_area().max(f64::MIN_POSITIVE);
        let split_cost = 1.0 + best.0 / parent;
        if best.0.is_infinite() {
            return Some(self.median_split(items, axis));
        }
        if n <= 8 && split_cost >= n as f64 {
            return None;
        }
        let split_bin = best.1;
        // Partition: bins < split_bin to the left.
        let mut i = 0;
        let mut j = n;
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

impl Bvh {
    /// Builds the BVH of `triangles` (vertex index triples into `positions`).
    ///
    /// Degenerate triangles (repeated or collinear corners) are accepted. Fails
    /// with a [`BvhError`] when an index is out of range or a used position is
    /// not finite. An empty triangle list gives an empty BVH whose queries
    /// return `None`.
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
        let mut builder = Builder {
            boxes: &boxes,
            centroids: &centroids,
            nodes: Vec::with_capacity(triangles.len()),
        };
        if !items.is_empty() {
            builder.build(&mut items, 0, 0);
        }
        let nodes = builder.nodes;
        let corners: Vec<[DVec3; 3]> = items.iter().map(|&t| tri_corners[t as usize]).collect();
        let mut slot = vec![0u32; triangles.len()];
        for (i, &t) in items.iter().enumerate() {
            slot[t as usize] = i as u32;
        }
        Ok(Bvh {
            nodes,
            corners,
            original: items,
            slot,
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
        self.nodes.first().map(|n| (n.lo, n.hi))
    }

    /// Closest point to `p` on the triangles: `(point, triangle index, squared
    /// distance)`, the triangle index being into the slice given to
    /// [`Bvh::build`]. `None` only when the BVH is empty or `p` is not finite.
    pub fn closest_point(&self, p: DVec3) -> Option<(DVec3, usize, f64)> {
        if !p.is_finite() {
            return None;
        }
        self.search(p, None)
            .map(|(q, s, d2)| (q, self.original[s as usize] as usize, d2))
    }

    /// Like [`Bvh::closest_point`], but first measures the distance to
    /// triangle `hint` (an index into the build input, typically the answer
    /// for a nearby point) so the traversal can prune from the start. The
    /// result is the same as without a hint (up to ties); an out-of-range hint
    /// is ignored.
    pub fn closest_point_hinted(&self, p: DVec3, hint: usize) -> Option<(DVec3, usize, f64)> {
        if !p.is_finite() {
            return None;
        }
        let slot = self.slot.get(hint).copied();
        self.search(p, slot)
            .map(|(q, s, d2)| (q, self.original[s as usize] as usize, d2))
    }

    /// Internal query working with leaf-order slots (used by the Hausdorff
    /// sampler to carry hints without translating indices).
    pub(crate) fn search(&self, p: DVec3, hint_slot: Option<u32>) -> Option<(DVec3, u32, f64)> {
        let root = self.nodes.first()?;
        let mut best_d2 = f64::INFINITY;
        let mut best = (DVec3::ZERO, 0u32);
        if let Some(s) = hint_slot.filter(|&s| (s as usize) < self.corners.len()) {
            let [a, b, c] = self.corners[s as usize];
            let q = closest_point_on_triangle(p, a, b, c);
            best_d2 = (p - q).length_squared();
            best = (q, s);
        }
        let mut stack = [(0u32, 0.0f64); STACK];
        let mut sp = 0usize;
        let mut node = 0u32;
        if box_distance_squared(p, root.lo, root.hi) > best_d2 {
            return Some((best.0, best.1, best_d2));
        }
        loop {
            let n = &self.nodes[node as usize];
            if n.count > 0 {
                let first = n.first as usize;
                for s in first..first + n.count as usize {
                    let [a, b, c] = self.corners[s];
                    let q = closest_point_on_triangle(p, a, b, c);
                    let d2 = (p - q).length_squared();
                    if d2 < best_d2 {
                        best_d2 = d2;
                        best = (q, s as u32);
                    }
                }
            } else {
                let (l, r) = (node + 1, n.first);
                let nl = &self.nodes[l as usize];
                let nr = &self.nodes[r as usize];
                let dl = box_distance_squared(p, nl.lo, nl.hi);
                let dr = box_distance_squared(p, nr.lo, nr.hi);
                let (near, dn, far, df) = if dl <= dr {
                    (l, dl, r, dr)
                } else {
                    (r, dr, l, dl)
                };
                if dn < best_d2 {
                    if df < best_d2 && sp < STACK {
                        stack[sp] = (far, df);
                        sp += 1;
                    }
                    node = near;
                    continue;
                }
            }
            // Pop the next box that can still hold something closer.
            loop {
                if sp == 0 {
                    return Some((best.0, best.1, best_d2));
                }
                sp -= 1;
                let (m, d) = stack[sp];
                if d < best_d2 {
                    node = m;
                    break;
                }
            }
        }
    }
}

/// Squared distance from `p` to the box `[lo, hi]` (0 inside).
#[inline]
fn box_distance_squared(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let d = (lo - p).max(p - hi).max(DVec3::ZERO);
    d.length_squared()
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
    if !(sum > 1e-24 * ab.length_squared() * ac.length_squared()) {
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

fn segment_closest(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 <= 0.0 {
        return a;
    }
    a + ab * ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
}
