//! An accelerator wrapper that records every query it answers, to replay the path tracer's
//! exact rays through Embree alone.

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

    fn record(&self, q: RecordedQuery) {
        let i = rayon::current_thread_index().unwrap_or(0) % self.lists.len();
        self.lists[i].lock().unwrap_or_else(|e| e.into_inner()).push(q);
    }

    /// Every query recorded, worker by worker.
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
        self.record(RecordedQuery { ray: *ray, tmin, tmax, occlusion: false });
        self.inner.intersect_deferred(ray, tmin, tmax)
    }

    fn occluded_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
        self.record(RecordedQuery { ray: *ray, tmin, tmax, occlusion: true });
        self.inner.occluded_deferred(ray, tmin, tmax)
    }

    /// Recorded as single closest-hit queries (replay traces them one by one); answered
    /// by the inner accelerator's packet query, so the render is the one it would be.
    fn intersect_packet_deferred(
        &self,
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: f32,
    ) -> [Option<Hit>; LANES] {
        for i in (0..LANES).filter(|&i| active[i]) {
            self.record(RecordedQuery { ray: rays.ray(i), tmin, tmax, occlusion: false });
        }
        self.inner.intersect_packet_deferred(rays, active, tmin, tmax)
    }

    fn deferred_error(&self) -> Result<(), AccelError> {
        self.inner.deferred_error()
    }
}

/// One parallel pass of `queries` through `accel` (on the current rayon pool); returns the
/// number of hits. Embree is called directly (the cheapest way the path tracer calls it: no
/// trait object, errors checked once per chunk), so that replay measures Embree alone.
pub fn replay(accel: &dyn Accel, queries: &[RecordedQuery]) -> Result<usize, AccelError> {
    match accel.as_embree() {
        Some(embree) => replay_on(embree, queries),
        None => replay_on(accel, queries),
    }
}

fn replay_on<A: Accel + ?Sized>(accel: &A, queries: &[RecordedQuery]) -> Result<usize, AccelError> {
    queries
        .par_chunks(512)
        .try_fold(
            || 0usize,
            |mut hits, chunk| {
                for q in chunk {
                    hits += if q.occlusion {
                        accel.occluded_deferred(&q.ray, q.tmin, q.tmax)
                    } else {
                        accel.intersect_deferred(&q.ray, q.tmin, q.tmax).is_some()
                    } as usize;
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
        let q = rec.into_queries();
        assert_eq!(q.len(), 2);
        assert_eq!((q[0].occlusion, q[0].tmax, q[1].occlusion, q[1].tmax), (false, 10.0, true, 3.0));
        assert_eq!(replay(&naive, &q).unwrap(), 1);
    }
}
