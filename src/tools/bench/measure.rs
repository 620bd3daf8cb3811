//! Timing ray queries: parallel passes over a query list on the current rayon pool, best pass
//! kept (the least disturbed by other work on the machine), in wall time and in CPU time.

use super::cputime::cpu_of;
use super::rays::Query;
use crate::accel::{Accel, AccelError, LANES};
use crate::geometry::{Hit, Ray, RayPacket};
use glam::Vec3;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// How long to measure: at least `min_passes` passes and at least `min_total` in all.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    pub min_passes: u32,
    pub min_total: Duration,
}

impl Timing {
    /// Whether to measure again after `passes` passes (at least one) taking `total` in all.
    pub fn wants_more(&self, passes: usize, total: Duration) -> bool {
        passes < self.min_passes.max(1) as usize || total < self.min_total
    }
}

/// The median of the finite values of `values` (NaN if there are none).
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
}

/// Queries per parallel work item: large enough to amortise scheduling, small enough to
/// balance two threads on small sets.
const CHUNK: usize = 512;

/// The answer to one query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Answer {
    Closest(Option<Hit>),
    Occluded(bool),
}

impl Answer {
    pub fn is_hit(&self) -> bool {
        match self {
            Answer::Closest(h) => h.is_some(),
            Answer::Occluded(o) => *o,
        }
    }
}

/// How a pass asks its queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Batch {
    /// One by one.
    Single,
    /// 8 at a time, consecutive queries together, with the packets' coherence hint
    /// ([`RayPacket::coherent`]): camera rays are coherent, random rays are not.
    Packets { coherent: bool },
}

/// One pass over `queries` (closest hit or any hit), asked as `batch` says; returns the
/// number of hits.
pub fn pass(accel: &dyn Accel, queries: &[Query], closest: bool, batch: Batch) -> Result<usize, AccelError> {
    queries
        .par_chunks(CHUNK)
        .try_fold(
            || 0usize,
            |mut hits, chunk| {
                if let Batch::Packets { coherent } = batch {
                    for group in chunk.chunks(LANES) {
                        let a = packet_answers(accel, group, closest, coherent)?;
                        hits += a[..group.len()].iter().filter(|a| a.is_hit()).count();
                    }
                    accel.deferred_error()?;
                    return Ok(hits);
                }
                for q in chunk {
                    let hit = if closest {
                        accel.intersect(&q.ray, 0.0, q.tmax)?.is_some()
                    } else {
                        accel.occluded(&q.ray, 0.0, q.tmax)?
                    };
                    hits += hit as usize;
                }
                Ok(hits)
            },
        )
        .try_reduce(|| 0, |a, b| Ok(a + b))
}

/// The answers to up to [`LANES`] queries as one packet query (errors deferred), in the first
/// `group.len()` lanes (no allocation: the timed pass calls this for every packet). Queries of
/// a packet share `tmax` in every workload (∞ for closest hits, 1 for shadow segments); a
/// group whose `tmax` differ is answered lane by lane.
fn packet_answers(
    accel: &dyn Accel,
    group: &[Query],
    closest: bool,
    coherent: bool,
) -> Result<[Answer; LANES], AccelError> {
    let tmax = group[0].tmax;
    if group.iter().any(|q| q.tmax != tmax) {
        let mut out = [Answer::Occluded(false); LANES];
        for (o, q) in out.iter_mut().zip(group) {
            *o = answer(accel, q, closest)?;
        }
        return Ok(out);
    }
    let rays: [Ray; LANES] = std::array::from_fn(|i| group.get(i).map_or(Ray::new(Vec3::ZERO, Vec3::Z), |q| q.ray));
    let mut rays = RayPacket::from_rays(&rays);
    rays.coherent = coherent;
    let active: [bool; LANES] = std::array::from_fn(|i| i < group.len());
    Ok(if closest {
        accel.intersect_packet_deferred(&rays, active, 0.0, tmax).map(Answer::Closest)
    } else {
        accel.occluded_packet_deferred(&rays, active, 0.0, [tmax; LANES]).map(Answer::Occluded)
    })
}

/// Wall and CPU time of a measurement.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Times {
    pub wall: Duration,
    /// CPU time of all threads (`None` where it cannot be read).
    pub cpu: Option<Duration>,
}

/// The best pass over `queries` (wall time and, separately, CPU time of the pool's threads),
/// and the hit count (the same every pass).
pub fn time_queries(
    accel: &dyn Accel,
    queries: &[Query],
    closest: bool,
    batch: Batch,
    timing: Timing,
) -> Result<(Times, usize), AccelError> {
    let (mut best, mut total, mut passes, mut hits) =
        (Times { wall: Duration::MAX, cpu: None }, Duration::ZERO, 0usize, 0usize);
    if queries.is_empty() {
        return Ok((Times::default(), 0));
    }
    while timing.wants_more(passes, total) {
        let ((h, t), cpu) = cpu_of(|| {
            let start = Instant::now();
            (pass(accel, queries, closest, batch), start.elapsed())
        });
        hits = h?;
        best.wall = best.wall.min(t);
        best.cpu = match (best.cpu, cpu) {
            (Some(b), Some(c)) => Some(b.min(c)),
            (b, c) => b.or(c),
        };
        total += t;
        passes += 1;
    }
    Ok((best, hits))
}

fn answer(accel: &dyn Accel, q: &Query, closest: bool) -> Result<Answer, AccelError> {
    Ok(if closest {
        Answer::Closest(accel.intersect(&q.ray, 0.0, q.tmax)?)
    } else {
        Answer::Occluded(accel.occluded(&q.ray, 0.0, q.tmax)?)
    })
}

/// Every query's answer (in parallel, not timed), asked as `batch` says.
pub fn answers(accel: &dyn Accel, queries: &[Query], closest: bool, batch: Batch) -> Result<Vec<Answer>, AccelError> {
    if let Batch::Packets { coherent } = batch {
        let groups: Vec<(usize, [Answer; LANES])> = queries
            .par_chunks(LANES)
            .map(|group| Ok((group.len(), packet_answers(accel, group, closest, coherent)?)))
            .collect::<Result<_, AccelError>>()?;
        accel.deferred_error()?;
        return Ok(groups.into_iter().flat_map(|(n, a)| a.into_iter().take(n)).collect());
    }
    queries.par_iter().map(|q| answer(accel, q, closest)).collect()
}

/// Times one pass of collecting every answer: the naive loop is measured this way, so its
/// slow pass also yields the reference answers. Work items are small (subsamples are short and
/// each query is slow), so both threads stay busy to the end.
pub fn time_answers(accel: &dyn Accel, queries: &[Query], closest: bool) -> Result<(Times, Vec<Answer>), AccelError> {
    let chunk = CHUNK.min(queries.len().div_ceil(rayon::current_num_threads() * 4)).max(1);
    let ((a, wall), cpu) = cpu_of(|| {
        let start = Instant::now();
        let a = queries
            .par_chunks(chunk)
            .map(|c| c.iter().map(|q| answer(accel, q, closest)).collect::<Result<Vec<_>, AccelError>>())
            .collect::<Result<Vec<_>, _>>();
        (a, start.elapsed())
    });
    Ok((Times { wall, cpu }, a?.into_iter().flatten().collect()))
}

#[cfg(test)]
mod tests {
    use super::median;

    #[test]
    fn median_of_odd_and_even_counts_skips_non_finite() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[f64::NAN, 1.0, 5.0, f64::INFINITY]), 3.0);
        assert!(median(&[]).is_nan());
    }
}
