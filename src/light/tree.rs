//! A light tree: many lights chosen by their importance at the shading point in O(log n).
//!
//! The choice by groups (`choice.rs`) weighs every group at every vertex, so it stops paying
//! beyond a few groups, and within a group (an emissive model's thousands of triangles) it
//! chooses by power alone: a point under one glowing panel samples the panels across the
//! model as often as the one above it. The tree (Conty Estevez and Kulla, "Importance
//! Sampling of Many Lights with Adaptive Tree Splitting", 2018; pbrt-v4's `BVHLightSampler`)
//! keeps every bounded light (triangle, sphere, point light) as a leaf of a binary tree whose
//! nodes bound the lights below them: a box, the sum of their luminance × area (as `choice`
//! weighs them), and a cone holding their normals. Choosing descends from the root, going to
//! each child in proportion to its importance at the point; the probability of the light
//! reached is the product of those ratios, which [`LightTree::probability`] recomputes by
//! climbing from the light's leaf.
//!
//! A node's importance at `p` is `phi · cos θ′ / max(d², r²)`: `d` the distance from `p` to
//! the centre of the node's box, `r` the radius of the sphere around that box, and `θ′` the
//! smallest angle the direction to `p` can make with a normal of the node's lights: the angle
//! to the cone's axis, less the cone's spread and less the angle θb the box's sphere subtends
//! (0 inside it); `cos θ′` is taken as `cos(θw − θo) + sin θb`, capped at 1, as `choice` does. Emitters here are two-sided, so cones are axes up to sign; a light can reach
//! `p` only where `cos θ′ > 0`. The bound is conservative: a light that can bring light to
//! `p` always has a probability above zero. Receiver orientation and occlusion are ignored,
//! as in the choice by groups.
//!
//! The tree is built top-down, each split chosen among 12 buckets per axis by the cost of
//! Conty Estevez and Kulla (power × the cone's orientation measure × the box's surface
//! area); splits by count take over past a depth of [`COST_DEPTH`], which bounds the depth
//! at about `COST_DEPTH + log2 n`.

use super::choice::ONE_BELOW;
use crate::geometry::Aabb;
use glam::Vec3;
use std::f32::consts::PI;

/// Below this depth splits minimise the cost; beyond it they halve the count.
const COST_DEPTH: usize = 40;

/// Buckets per axis among which a split is chosen.
const BUCKETS: usize = 12;

/// Normals a set of two-sided emitters can have: within `acos(cos_o)` of `±w`, or every
/// direction (`cos_o <= 0`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Cone {
    w: Vec3,
    cos_o: f32,
}

impl Cone {
    /// Every direction (spheres and point lights emit all around).
    pub(super) const ALL: Cone = Cone { w: Vec3::Z, cos_o: -1.0 };

    /// The normal of a flat emitter (either side).
    pub(super) fn normal(n: Vec3) -> Cone {
        if n.is_finite() && n.length_squared() > 0.0 { Cone { w: n.normalize(), cos_o: 1.0 } } else { Cone::ALL }
    }

    fn is_all(&self) -> bool {
        self.cos_o <= 0.0
    }

    /// The spread θo in radians (π/2 or more: every direction).
    fn theta(&self) -> f32 {
        if self.is_all() { PI } else { self.cos_o.min(1.0).acos() }
    }

    /// The smallest cone holding both (as two-sided cones: `b`'s axis is flipped toward
    /// `a`'s when that is tighter).
    fn union(a: Cone, b: Cone) -> Cone {
        if a.is_all() || b.is_all() {
            return Cone::ALL;
        }
        let bw = if a.w.dot(b.w) < 0.0 { -b.w } else { b.w };
        let (ta, tb) = (a.theta(), b.theta());
        let td = a.w.dot(bw).clamp(-1.0, 1.0).acos();
        if (td + tb).min(PI) <= ta {
            return a;
        }
        if (td + ta).min(PI) <= tb {
            return Cone { w: bw, cos_o: b.cos_o };
        }
        let to = 0.5 * (ta + td + tb);
        if to >= 0.5 * PI {
            return Cone::ALL;
        }
        // The new axis: a's, turned toward b's by to − ta in their common plane.
        let axis = a.w.cross(bw);
        let w = if axis.length_squared() > 1e-12 {
            let turn = to - ta;
            let perp = axis.normalize().cross(a.w); // unit, in the plane, toward b
            (a.w * turn.cos() + perp * turn.sin()).normalize()
        } else {
            a.w
        };
        // Rounding can leave either cone a hair outside: widen by a small margin.
        let spread = (to + 1e-4).min(0.5 * PI);
        if spread >= 0.5 * PI { Cone::ALL } else { Cone { w, cos_o: spread.cos() } }
    }

    /// The orientation measure of the cone with emission over a hemisphere around each
    /// normal (θe = π/2): the solid angle the emitted light can leave through, weighted by
    /// cosine, as Conty Estevez and Kulla define it; π for a flat emitter, 4π for all
    /// directions.
    fn measure(&self) -> f32 {
        let to = self.theta();
        let tw = (to + 0.5 * PI).min(PI);
        let (so, co) = (to.sin(), to.cos());
        2.0 * PI * (1.0 - co) + 0.5 * PI * (2.0 * tw * so - (to - 2.0 * tw).cos() - 2.0 * to * so + co)
    }
}

/// What a node (or one light) is bounded by.
#[derive(Clone, Copy, Debug)]
pub(super) struct Bounds {
    pub(super) aabb: Aabb,
    /// Luminance × area for surfaces (× π r² for spheres), the intensity's luminance for
    /// point lights: what `choice` calls the scale.
    pub(super) phi: f32,
    pub(super) cone: Cone,
}

impl Bounds {
    fn union(&self, o: &Bounds) -> Bounds {
        Bounds { aabb: self.aabb.union(&o.aabb), phi: self.phi + o.phi, cone: Cone::union(self.cone, o.cone) }
    }

    fn cost(&self) -> f32 {
        let d = self.aabb.diagonal().max(Vec3::ZERO);
        let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        self.phi * self.cone.measure() * area
    }
}

/// A node as the choice reads it.
#[derive(Clone, Copy, Debug)]
struct Node {
    center: Vec3,
    radius: f32,
    w: Vec3,
    cos_o: f32,
    sin_o: f32,
    phi: f32,
    /// Inner node: the index of the second child (the first follows the node). Leaf: the
    /// light's index in the set.
    index: u32,
    leaf: bool,
}

impl Node {
    fn new(b: &Bounds, index: u32, leaf: bool) -> Node {
        let (center, radius) =
            if b.aabb.is_valid() { (b.aabb.center(), 0.5 * b.aabb.diagonal().length()) } else { (Vec3::ZERO, 0.0) };
        let cos_o = b.cone.cos_o.clamp(-1.0, 1.0);
        Node {
            center,
            radius,
            w: b.cone.w,
            cos_o,
            sin_o: (1.0 - cos_o * cos_o).max(0.0).sqrt(),
            phi: b.phi,
            index,
            leaf,
        }
    }

    /// The light the node's emitters can bring to `p` (see the module documentation); finite.
    #[inline]
    fn importance(&self, p: Vec3) -> f32 {
        if !(self.phi > 0.0) {
            return 0.0;
        }
        let to_p = p - self.center;
        let d2 = to_p.length_squared();
        let r2 = self.radius * self.radius;
        let cos_t = if d2 <= r2 || self.cos_o <= 0.0 {
            1.0
        } else {
            let inv_d = d2.sqrt().recip();
            let cos_w = (self.w.dot(to_p).abs() * inv_d).min(1.0);
            if cos_w >= self.cos_o {
                1.0
            } else {
                // cos(θw − θo), then widened by θb as cos(θx − θb) ≈ cos θx + sin θb (capped
                // at 1): one square root fewer than the exact cosine, and zero exactly where
                // it is (θx − θb ≥ π/2 ⇔ cos θx + sin θb ≤ 0).
                let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
                let cos_x = cos_w * self.cos_o + sin_w * self.sin_o;
                (cos_x + self.radius * inv_d).min(1.0)
            }
        };
        if !(cos_t > 0.0) {
            return 0.0;
        }
        let v = self.phi * cos_t / d2.max(r2);
        if v.is_finite() { v } else { f32::MAX }
    }
}

/// Bytes the tree holds per light: two nodes (a leaf and, on average, one inner node), their
/// parents, and the light's leaf.
pub(super) const BYTES_PER_LIGHT: usize = 2 * std::mem::size_of::<Node>() + 2 * 4 + 4;

/// The tree over the bounded lights of a [`super::LightSet`].
#[derive(Clone, Debug)]
pub(super) struct LightTree {
    nodes: Vec<Node>,
    /// Per node, its parent (`u32::MAX` for the root).
    parent: Vec<u32>,
    /// Per light of the set, its leaf (`u32::MAX`: not in the tree).
    leaf_of: Vec<u32>,
    depth: usize,
}

/// One light to build the tree over.
#[derive(Clone, Copy, Debug)]
struct Item {
    bounds: Bounds,
    centroid: Vec3,
    light: u32,
}

impl LightTree {
    /// The tree over `lights` (each light's index in the set, and its bounds) of a set of
    /// `set_len` lights; lights of zero `phi` are left out (never chosen). `None` when none
    /// is left.
    pub(super) fn build(set_len: usize, lights: impl Iterator<Item = (u32, Bounds)>) -> Option<LightTree> {
        let mut items: Vec<Item> = lights
            .filter(|(_, b)| b.phi > 0.0 && b.phi.is_finite() && b.aabb.is_valid())
            .map(|(light, bounds)| Item { bounds, centroid: bounds.aabb.center(), light })
            .collect();
        if items.is_empty() {
            return None;
        }
        let mut tree = LightTree {
            nodes: Vec::with_capacity(2 * items.len()),
            parent: Vec::with_capacity(2 * items.len()),
            leaf_of: vec![u32::MAX; set_len],
            depth: 0,
        };
        tree.build_node(&mut items, u32::MAX, 0);
        Some(tree)
    }

    fn build_node(&mut self, items: &mut [Item], parent: u32, depth: usize) -> Bounds {
        self.depth = self.depth.max(depth);
        let at = self.nodes.len() as u32;
        if let [item] = items {
            self.nodes.push(Node::new(&item.bounds, item.light, true));
            self.parent.push(parent);
            self.leaf_of[item.light as usize] = at;
            return item.bounds;
        }
        self.nodes.push(Node::new(&items[0].bounds, 0, false)); // filled in below
        self.parent.push(parent);
        let mid = split(items, depth);
        let (left, right) = items.split_at_mut(mid);
        let lb = self.build_node(left, at, depth + 1);
        let second = self.nodes.len() as u32;
        let rb = self.build_node(right, at, depth + 1);
        let b = lb.union(&rb);
        self.nodes[at as usize] = Node::new(&b, second, false);
        b
    }

    pub(super) fn depth(&self) -> usize {
        self.depth
    }

    /// The root's importance at `p`: how much the whole tree weighs against the background.
    #[inline]
    pub(super) fn importance(&self, p: Vec3) -> f32 {
        self.nodes[0].importance(p)
    }

    /// The light that `u` in [0, 1) reaches from the root at `p`, and its probability; `None`
    /// where no light of the tree can reach `p`.
    #[inline(never)]
    pub(super) fn pick(&self, p: Vec3, mut u: f32) -> Option<(usize, f32)> {
        let mut n = 0usize;
        let mut prob = 1.0f32;
        loop {
            let node = &self.nodes[n];
            if node.leaf {
                return Some((node.index as usize, prob));
            }
            let (a, b) = (n + 1, node.index as usize);
            let (ia, ib) = (self.nodes[a].importance(p), self.nodes[b].importance(p));
            let total = ia + ib;
            if !(total > 0.0) {
                return None;
            }
            let pa = ia / total;
            if u < pa {
                u = (u / pa).min(ONE_BELOW);
                prob *= pa;
                n = a;
            } else {
                let pb = 1.0 - pa;
                u = ((u - pa) / pb).clamp(0.0, ONE_BELOW);
                prob *= pb;
                n = b;
            }
        }
    }

    /// The probability that [`LightTree::pick`] at `p` reaches light `light`.
    #[inline(never)]
    pub(super) fn probability(&self, p: Vec3, light: usize) -> f32 {
        let Some(&leaf) = self.leaf_of.get(light) else { return 0.0 };
        if leaf == u32::MAX {
            return 0.0;
        }
        let mut n = leaf as usize;
        let mut prob = 1.0f32;
        while self.parent[n] != u32::MAX {
            let up = self.parent[n] as usize;
            let (a, b) = (up + 1, self.nodes[up].index as usize);
            let (ia, ib) = (self.nodes[a].importance(p), self.nodes[b].importance(p));
            let total = ia + ib;
            if !(total > 0.0) {
                return 0.0;
            }
            let pa = ia / total;
            prob *= if n == a { pa } else { 1.0 - pa };
            n = up;
        }
        prob
    }
}

/// Reorders `items` and returns where the second child's start: at the cheapest of the
/// bucket boundaries over the three axes, or at half the count (past [`COST_DEPTH`], or when
/// no boundary separates anything). Deterministic: ties go to the first axis and boundary.
fn split(items: &mut [Item], depth: usize) -> usize {
    let cb = items.iter().fold(Aabb::EMPTY, |b, it| b.grow(it.centroid));
    let extent = cb.diagonal();
    let max_extent = extent.max_element();
    let by_count = |items: &mut [Item], axis: usize| {
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |a, b| {
            a.centroid[axis].total_cmp(&b.centroid[axis]).then(a.light.cmp(&b.light))
        });
        mid
    };
    let longest = (0..3).fold(0, |best, a| if extent[a] > extent[best] { a } else { best });
    if depth >= COST_DEPTH || !(max_extent > 0.0) || !max_extent.is_finite() {
        return by_count(items, longest);
    }
    let bucket_of = |c: Vec3, axis: usize| -> usize {
        let t = (c[axis] - cb.min[axis]) / extent[axis];
        ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
    };
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, boundary)
    for axis in 0..3 {
        if !(extent[axis] > 0.0) {
            continue;
        }
        let mut buckets: [Option<Bounds>; BUCKETS] = [None; BUCKETS];
        for it in items.iter() {
            let k = bucket_of(it.centroid, axis);
            buckets[k] = Some(buckets[k].map_or(it.bounds, |b| b.union(&it.bounds)));
        }
        // Cost of [0, k) against [k, BUCKETS), from both ends.
        let mut below = [0.0f32; BUCKETS];
        let mut acc: Option<Bounds> = None;
        for k in 1..BUCKETS {
            if let Some(b) = buckets[k - 1] {
                acc = Some(acc.map_or(b, |a| a.union(&b)));
            }
            below[k] = acc.map_or(f32::NAN, |a| a.cost());
        }
        let mut acc: Option<Bounds> = None;
        // Cones far wider than boxes along an axis this short would let the split follow
        // orientation alone: weigh the axis by how short it is (pbrt's regularisation).
        let stretch = max_extent / extent[axis];
        for k in (1..BUCKETS).rev() {
            if let Some(b) = buckets[k] {
                acc = Some(acc.map_or(b, |a| a.union(&b)));
            }
            let (Some(above), lo) = (acc, below[k]) else { continue };
            if lo.is_nan() {
                continue;
            }
            let cost = stretch * (lo + above.cost());
            if cost.is_finite() && best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, k));
            }
        }
    }
    let Some((_, axis, k)) = best else { return by_count(items, longest) };
    // Partition in place: items of buckets below k first.
    let mut mid = 0;
    for i in 0..items.len() {
        if bucket_of(items[i].centroid, axis) < k {
            items.swap(i, mid);
            mid += 1;
        }
    }
    if mid == 0 || mid == items.len() { by_count(items, longest) } else { mid }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator for the tests' scenes.
    struct Lcg(u64);
    impl Lcg {
        fn f(&mut self) -> f32 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn v(&mut self) -> Vec3 {
            Vec3::new(self.f(), self.f(), self.f()) * 2.0 - 1.0
        }
    }

    /// Random small triangles (as bounds), spheres and points.
    fn lights(n: usize, seed: u64) -> Vec<(u32, Bounds, Option<[Vec3; 3]>)> {
        let mut r = Lcg(seed);
        (0..n)
            .map(|i| {
                let c = r.v() * 10.0;
                let phi = 0.1 + r.f();
                match i % 5 {
                    0 => {
                        let aabb = Aabb::from_point(c);
                        (i as u32, Bounds { aabb, phi, cone: Cone::ALL }, None)
                    }
                    1 => {
                        let rad = 0.2 * r.f();
                        let aabb = Aabb::new(c - rad, c + rad);
                        (i as u32, Bounds { aabb, phi, cone: Cone::ALL }, None)
                    }
                    _ => {
                        let t = [c, c + r.v() * 0.5, c + r.v() * 0.5];
                        let n = (t[1] - t[0]).cross(t[2] - t[0]);
                        let aabb = t.iter().fold(Aabb::EMPTY, |b, v| b.grow(*v));
                        (i as u32, Bounds { aabb, phi, cone: Cone::normal(n) }, Some(t))
                    }
                }
            })
            .collect()
    }

    fn tree(ls: &[(u32, Bounds, Option<[Vec3; 3]>)]) -> LightTree {
        LightTree::build(ls.len(), ls.iter().map(|(i, b, _)| (*i, *b))).unwrap()
    }

    #[test]
    fn probabilities_sum_to_one_and_match_what_pick_returns() {
        let ls = lights(300, 1);
        let t = tree(&ls);
        let mut r = Lcg(7);
        for _ in 0..50 {
            let p = r.v() * 12.0;
            let sum: f64 = (0..ls.len()).map(|i| t.probability(p, i) as f64).sum();
            assert!((sum - 1.0).abs() < 1e-4, "sum {sum} at {p}");
            for _ in 0..20 {
                let (i, prob) = t.pick(p, r.f()).unwrap();
                let again = t.probability(p, i);
                assert!((prob / again - 1.0).abs() < 1e-5, "{prob} vs {again}");
            }
        }
    }

    #[test]
    fn picks_follow_the_probabilities() {
        // 40 lights, 200,000 picks at one point: each light's frequency within 5 standard
        // deviations of its probability (fixed seed).
        let ls = lights(40, 2);
        let t = tree(&ls);
        let p = Vec3::new(0.5, 1.0, -2.0);
        let n = 200_000;
        let mut count = vec![0u32; ls.len()];
        let mut r = Lcg(3);
        for _ in 0..n {
            count[t.pick(p, r.f()).unwrap().0] += 1;
        }
        for (i, &c) in count.iter().enumerate() {
            let q = t.probability(p, i) as f64;
            let sd = (n as f64 * q * (1.0 - q)).sqrt().max(1.0);
            assert!((c as f64 - n as f64 * q).abs() < 5.0 * sd, "light {i}: {c} picks for probability {q}");
        }
    }

    #[test]
    fn a_light_that_can_reach_a_point_can_be_chosen_there() {
        // Points in front of a triangle (either side, it is two-sided), near and far: the
        // conservative bound never gives it probability 0.
        let ls = lights(500, 4);
        let t = tree(&ls);
        let mut r = Lcg(5);
        for (i, _, tri) in &ls {
            let Some(tri) = tri else { continue };
            let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
            let c = (tri[0] + tri[1] + tri[2]) / 3.0;
            for _ in 0..10 {
                let dir = r.v();
                let dir = if dir.dot(n).abs() < 0.05 { n } else { dir };
                let p = c + dir * (0.01 + 20.0 * r.f());
                assert!(t.probability(p, *i as usize) > 0.0, "light {i} at {p}");
            }
        }
    }

    #[test]
    fn nearby_lights_are_chosen_more_than_their_power_says() {
        // A row of equal lights along x: from a point over the first, it gets far more than
        // its power's share (1/64).
        let ls: Vec<(u32, Bounds)> = (0..64)
            .map(|i| {
                let c = Vec3::new(i as f32, 0.0, 0.0);
                (i, Bounds { aabb: Aabb::new(c - 0.1, c + 0.1), phi: 1.0, cone: Cone::normal(Vec3::Y) })
            })
            .collect();
        let t = LightTree::build(64, ls.into_iter()).unwrap();
        let p = Vec3::new(0.0, 0.5, 0.0);
        assert!(t.probability(p, 0) > 0.3, "{}", t.probability(p, 0));
        assert!(t.probability(p, 63) < 0.01);
        assert!(t.depth() <= 8, "a balanced row: depth {}", t.depth());
    }

    #[test]
    fn cones_hold_both_and_measure_as_expected() {
        let a = Cone::normal(Vec3::X);
        let b = Cone::normal(Vec3::Y);
        let u = Cone::union(a, b);
        for w in [Vec3::X, Vec3::Y, -Vec3::X] {
            assert!(u.w.dot(w).abs() >= u.cos_o - 1e-6, "{u:?} misses {w}");
        }
        // Opposite normals of two-sided emitters are one axis.
        let c = Cone::union(a, Cone::normal(-Vec3::X));
        assert!(c.cos_o > 0.9999, "{c:?}");
        assert!((Cone::normal(Vec3::Z).measure() - PI).abs() < 1e-5);
        assert!((Cone::ALL.measure() - 4.0 * PI).abs() < 1e-4);
        assert!(Cone::union(Cone::ALL, a).is_all());
    }

    #[test]
    fn identical_lights_build_a_balanced_tree() {
        // A thousand point lights at one place: no bucket separates them, counts split.
        let b = Bounds { aabb: Aabb::from_point(Vec3::ONE), phi: 1.0, cone: Cone::ALL };
        let t = LightTree::build(1000, (0..1000).map(|i| (i, b))).unwrap();
        assert!(t.depth() <= 10, "depth {}", t.depth());
        let p = Vec3::ZERO;
        assert!((t.probability(p, 17) - 1e-3).abs() < 1e-5);
        // Zero-power lights are left out.
        let z = Bounds { phi: 0.0, ..b };
        let t = LightTree::build(3, [(0, b), (1, z), (2, b)].into_iter()).unwrap();
        assert_eq!(t.probability(p, 1), 0.0);
        assert!((t.probability(p, 2) - 0.5).abs() < 1e-6);
        assert!(LightTree::build(1, [(0, z)].into_iter()).is_none());
    }
}
