//! An accelerator wrapper that records every query it answers, to replay the path tracer's
//! exact rays through Embree alone, the way the path tracer traced them: packets as packets,
//! single rays one by one.

use crate::accel::{Accel, AccelError, LANES};
use crate::geometry::{Hit, Ray, RayPacket};
use rayon::prelude::*;
use std::sync::Mutex;

/// One recorded query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecordedQuery {
    pub ray: Ray,
    pub tmin: f32,
    pub tmax: f32,
    /// `true` for an occlusion (any-hit) query, `false` for a closest hit.
    pub occlusion: bool,
    /// On the first ray of a packet query, the packet's rays (this one and the next
    /// `packet - 1` queries, in lanes 0, 1, …, as the path tracer's active lanes are); 0 on the
    /// others and on single queries.
    pub packet: u8,
    /// The packet's coherence hint ([`RayPacket::coherent`]), on its first ray.
    pub coherent: bool,
}

/// Forwards every query to `inner` and keeps a copy of it. Each rayon worker appends to its
/// own list (no contention), so a list holds whole tiles in the order that worker traced them.
pub struct RecordingAccel<'a> {
    inner: &'a dyn Accel,
    lists: Vec<Mutex<Vec<RecordedQuery>>>,
}

impl<'a> RecordingAccel<'a> {
    /// Enough lists for `threads` workers (more do no harm: they are only shared).
    pub fn new(inner: &'a dyn Accel, threads: usize) -> Self {
        RecordingAccel { inner, lists: (0..threads.max(1)).map(|_| Mutex::new(Vec::new())).collect() }
    }

    /// The calling worker's list: a packet's queries stay together in it.
    fn list(&self) -> &Mutex<Vec<RecordedQuery>> {
        &self.lists[rayon::current_thread_index().unwrap_or(0) % self.lists.len()]
    }

    fn record(&self, q: RecordedQuery) {
        self.list().lock().unwrap_or_else(|e| e.into_inner()).push(q);
    }

    /// Every query recorded, worker by worker.
    fn record_packet(&self, rays: &RayPacket, active: [bool; LANES], tmin: f32, tmax: [f32; LANES], occlusion: bool) {
        let n = active.iter().take_while(|&&a| a).count();
        assert!(active[n..].iter().all(|&a| !a), "recorded packets have their active lanes first");
        let mut list = self.list().lock().unwrap_or_else(|e| e.into_inner());
        for (i, &tmax) in tmax.iter().enumerate().take(n) {
            let packet = if i == 0 { n as u8 } else { 0 };
            let coherent = i == 0 && rays.coherent;
            list.push(RecordedQuery { ray: rays.ray(i), tmin, tmax, occlusion, packet, coherent });
        }
    }

    pub fn into_queries(self) -> Vec<RecordedQuery> {
        self.lists.into_iter().flat_map(|l| l.into_inner().unwrap_or_else(|e| e.into_inner())).collect()
    }
}

impl Accel for RecordingAccel<'_> {
    fn name(&self) -> &'static str {
        "recording"
    }

    fn image_key(&self) -> String {
        self.inner.image_key()
    }

    fn intersect_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<Hit> {
        self.record(RecordedQuery { ray: *ray, tmin, tmax, occlusion: false, packet: 0, coherent: false });
        self.inner.intersect_deferred(ray, tmin, tmax)
    }

    fn occluded_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
        self.record(RecordedQuery { ray: *ray, tmin, tmax, occlusion: true, packet: 0, coherent: false });
        self.inner.occluded_deferred(ray, tmin, tmax)
    }

    /// Recorded as one packet query of its active lanes (a prefix of the packet, as the path
    /// tracer's are; checked), so that replay traces it as the path tracer did.
    fn intersect_packet_deferred(
        &self,
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: f32,
    ) -> [Option<Hit>; LANES] {
        self.record_packet(rays, active, tmin, [tmax; LANES], false);
        self.inner.intersect_packet_deferred(rays, active, tmin, tmax)
    }

    /// Recorded as a closest-hit packet is, with each lane's `tmax`.
    fn occluded_packet_deferred(
        &self,
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: [f32; LANES],
    ) -> [bool; LANES] {
        self.record_packet(rays, active, tmin, tmax, true);
        self.inner.occluded_packet_deferred(rays, active, tmin, tmax)
    }

    fn deferred_error(&self) -> Result<(), AccelError> {
        self.inner.deferred_error()
    }
}

/// The queries cut into chunks of about 512 for the replay's threads, never inside a packet.
pub fn replay_chunks(queries: &[RecordedQuery]) -> Vec<std::ops::Range<usize>> {
    let mut chunks = Vec::new();
    let mut start = 0;
    let mut i = 0;
    while i < queries.len() {
        i += (queries[i].packet as usize).max(1);
        if i - start >= 512 || i >= queries.len() {
            chunks.push(start..i.min(queries.len()));
            start = i;
        }
    }
    chunks
}

/// One parallel pass of `queries` (cut by [`replay_chunks`]) through `accel` (on the current
/// rayon pool), each packet as one packet query and every other query alone; returns the
/// number of hits. Embree is called directly (the cheapest way the path tracer calls it: no
/// trait object, errors checked once per chunk), so that replay measures Embree alone.
pub fn replay(
    accel: &dyn Accel,
    queries: &[RecordedQuery],
    chunks: &[std::ops::Range<usize>],
) -> Result<usize, AccelError> {
    match accel.as_embree() {
        Some(embree) => replay_on(embree, queries, chunks),
        None => replay_on(accel, queries, chunks),
    }
}

fn replay_on<A: Accel + ?Sized>(
    accel: &A,
    queries: &[RecordedQuery],
    chunks: &[std::ops::Range<usize>],
) -> Result<usize, AccelError> {
    chunks
        .par_iter()
        .try_fold(
            || 0usize,
            |mut hits, range| {
                let chunk = &queries[range.clone()];
                let mut i = 0;
                while i < chunk.len() {
                    let q = &chunk[i];
                    if q.packet > 0 {
                        let n = q.packet as usize;
                        let mut rays = RayPacket::splat(&q.ray);
                        rays.coherent = q.coherent;
                        for (lane, p) in chunk[i..i + n].iter().enumerate() {
                            rays.set(lane, &p.ray);
                        }
                        let active = std::array::from_fn(|lane| lane < n);
                        hits += if q.occlusion {
                            let tmax = std::array::from_fn(|lane| chunk.get(i + lane).map_or(0.0, |p| p.tmax));
                            let blocked = accel.occluded_packet_deferred(&rays, active, q.tmin, tmax);
                            blocked.iter().filter(|&&b| b).count()
                        } else {
                            let found = accel.intersect_packet_deferred(&rays, active, q.tmin, q.tmax);
                            found.iter().filter(|h| h.is_some()).count()
                        };
                        i += n;
                        continue;
                    }
                    hits += if q.occlusion {
                        accel.occluded_deferred(&q.ray, q.tmin, q.tmax)
                    } else {
                        accel.intersect_deferred(&q.ray, q.tmin, q.tmax).is_some()
                    } as usize;
                    i += 1;
                }
                accel.deferred_error()?;
                Ok(hits)
            },
        )
        .try_reduce(|| 0, |a, b| Ok(a + b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::NaiveAccel;
    use crate::geometry::{Geometry, Sphere};
    use glam::Vec3;

    #[test]
    fn records_what_it_forwards() {
        let g = [Geometry::Spheres(vec![Sphere::new(Vec3::ZERO, 1.0)].into())];
        let naive = NaiveAccel::new(&g);
        let rec = RecordingAccel::new(&naive, 2);
        let r = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        assert_eq!(rec.intersect(&r, 0.0, 10.0).unwrap().map(|h| h.t), Some(4.0));
        assert!(!rec.occluded(&r, 0.0, 3.0).unwrap());
        // A packet of three active lanes: recorded as one packet of three rays.
        let mut rays = RayPacket::splat(&r);
        rays.coherent = true;
        rays.set(1, &Ray::new(Vec3::new(5.0, 0.0, -5.0), Vec3::Z));
        let active = std::array::from_fn(|i| i < 3);
        let found = rec.intersect_packet_deferred(&rays, active, 0.0, 10.0);
        assert_eq!(found.iter().filter(|h| h.is_some()).count(), 2);
        let q = rec.into_queries();
        assert_eq!(q.len(), 5);
        assert_eq!((q[0].occlusion, q[0].tmax, q[1].occlusion, q[1].tmax), (false, 10.0, true, 3.0));
        assert_eq!(q.iter().map(|q| q.packet).collect::<Vec<_>>(), [0, 0, 3, 0, 0]);
        assert_eq!(q[3].ray.o.x, 5.0);
        assert_eq!(q.iter().map(|q| q.coherent).collect::<Vec<_>>(), [false, false, true, false, false]);
        // Replayed whole: the single hit and the packet's two.
        let chunks = replay_chunks(&q);
        assert_eq!(chunks, vec![0..5]);
        assert_eq!(replay(&naive, &q, &chunks).unwrap(), 3);
    }

    #[test]
    fn records_shadow_packets_with_each_lane_s_end() {
        let g = [Geometry::Spheres(vec![Sphere::new(Vec3::ZERO, 1.0)].into())];
        let naive = NaiveAccel::new(&g);
        let rec = RecordingAccel::new(&naive, 1);
        // Two shadow rays toward the sphere (4 away): the first stops short of it.
        let r = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        let rays = RayPacket::splat(&r);
        let active = std::array::from_fn(|i| i < 2);
        let mut tmax = [0.0; LANES];
        tmax[..2].copy_from_slice(&[3.0, 10.0]);
        assert_eq!(rec.occluded_packet_deferred(&rays, active, 0.0, tmax)[..2], [false, true]);
        let q = rec.into_queries();
        let recorded: Vec<_> = q.iter().map(|q| (q.occlusion, q.packet, q.tmax)).collect();
        assert_eq!(recorded, [(true, 2, 3.0), (true, 0, 10.0)]);
        // Replayed as one packet, each lane on its own interval: one blocked.
        assert_eq!(replay(&naive, &q, &replay_chunks(&q)).unwrap(), 1);
    }

    #[test]
    fn chunks_never_cut_a_packet() {
        let r = Ray::new(Vec3::ZERO, Vec3::Z);
        let single = RecordedQuery { ray: r, tmin: 0.0, tmax: 1.0, occlusion: false, packet: 0, coherent: false };
        let mut q = vec![single; 510];
        // A packet of 8 across the 512 mark, then singles.
        q.push(RecordedQuery { packet: 8, ..single });
        q.extend([single; 7]);
        q.extend([single; 600]);
        let chunks = replay_chunks(&q);
        assert_eq!(chunks[0], 0..518);
        assert_eq!(chunks.iter().map(|c| c.len()).sum::<usize>(), q.len());
        assert!(chunks.windows(2).all(|w| w[0].end == w[1].start));
    }
}
