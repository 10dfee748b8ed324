//! Discrete Curve Evolution with a tolerance, driven by a binary heap.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::geometry::{Segment, Vec2};

/// Simplifies an open polygonal curve through `points` by Discrete Curve Evolution.
///
/// Writes the indices of the kept vertices (ascending, always including the first and the last
/// point) into `vertices`. Every input point stays within `tolerance_m` of the simplified curve
/// edge that replaced it.
///
/// ```
/// use polymap::extract::simplify_run;
/// use polymap::geometry::Vec2;
/// let pts = [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.01), Vec2::new(2.0, 0.0), Vec2::new(2.0, 1.0)];
/// let mut v = Vec::new();
/// simplify_run(&pts, 0.05, &mut v);
/// assert_eq!(v, vec![0, 2, 3]);
/// ```
pub fn simplify_run(points: &[Vec2], tolerance_m: f64, vertices: &mut Vec<usize>) {
    vertices.clear();
    let n = points.len();
    if n <= 2 {
        vertices.extend(0..n);
        return;
    }
    let mut curve = Curve::new(n);
    let mut heap = BinaryHeap::with_capacity(2 * n);
    for i in 1..n - 1 {
        heap.push(Entry {
            relevance: relevance(points, i - 1, i, i + 1),
            version: 0,
            index: i,
        });
    }
    let tolerance_2 = tolerance_m * tolerance_m;
    while let Some(e) = heap.pop() {
        if !curve.alive[e.index] || curve.version[e.index] != e.version {
            continue;
        }
        let (a, b) = (curve.prev[e.index], curve.next[e.index]);
        if !within_tolerance(points, a, b, tolerance_2) {
            continue; // set aside; pushed again when a neighbour goes
        }
        curve.remove(e.index);
        for v in [a, b] {
            if v != 0 && v != n - 1 {
                curve.version[v] += 1;
                let r = relevance(points, curve.prev[v], v, curve.next[v]);
                heap.push(Entry {
                    relevance: r,
                    version: curve.version[v],
                    index: v,
                });
            }
        }
    }
    vertices.extend((0..n).filter(|&i| curve.alive[i]));
}

/// A doubly linked list over point indices.
struct Curve {
    prev: Vec<usize>,
    next: Vec<usize>,
    alive: Vec<bool>,
    version: Vec<u32>,
}

impl Curve {
    fn new(n: usize) -> Self {
        Curve {
            prev: (0..n).map(|i| i.saturating_sub(1)).collect(),
            next: (0..n).map(|i| (i + 1).min(n - 1)).collect(),
            alive: vec![true; n],
            version: vec![0; n],
        }
    }

    fn remove(&mut self, i: usize) {
        let (a, b) = (self.prev[i], self.next[i]);
        self.next[a] = b;
        self.prev[b] = a;
        self.alive[i] = false;
    }
}

/// The DCE relevance `β·l1·l2/(l1+l2)` of vertex `v` between `u` and `w`.
fn relevance(points: &[Vec2], u: usize, v: usize, w: usize) -> f64 {
    let e1 = points[v] - points[u];
    let e2 = points[w] - points[v];
    let (l1, l2) = (e1.length(), e2.length());
    if l1 + l2 <= 0.0 {
        return 0.0;
    }
    let beta = e1.perp_dot(e2).atan2(e1.dot(e2)).abs();
    beta * l1 * l2 / (l1 + l2)
}

/// True when all points strictly between `a` and `b` lie within the tolerance of edge `a`–`b`.
fn within_tolerance(points: &[Vec2], a: usize, b: usize, tolerance_2: f64) -> bool {
    let edge = Segment::new(points[a], points[b]);
    points[a + 1..b]
        .iter()
        .all(|p| edge.distance_2_to_point(*p) <= tolerance_2)
}

/// A heap entry: the smallest relevance pops first; ties go to the lower index.
#[derive(Debug, Clone, Copy)]
struct Entry {
    relevance: f64,
    version: u32,
    index: usize,
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Entry {}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: BinaryHeap is a max-heap.
        other
            .relevance
            .total_cmp(&self.relevance)
            .then_with(|| other.index.cmp(&self.index))
    }
}
