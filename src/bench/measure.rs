//! Timing ray queries: parallel passes over a query list on the current rayon pool, best pass
//! kept (the least disturbed by other work on the machine).

use super::rays::Query;
use crate::accel::{Accel, AccelError};
use crate::geometry::Hit;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// How long to measure: at least `min_passes` passes and at least `min_total` in all.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    pub min_passes: u32,
    pub min_total: Duration,
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

/// One pass over `queries` (closest hit or any hit); returns the number of hits.
pub fn pass(accel: &dyn Accel, queries: &[Query], closest: bool) -> Result<usize, AccelError> {
    queries.par_chunks(CHUNK).try_fold(
        || 0usize,
        |mut hits, chunk| {
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

/// The best pass time over `queries`, and the hit count (the same every pass).
pub fn time_queries(accel: &dyn Accel, queries: &[Query], closest: bool, timing: Timing) -> Result<(Duration, usize), AccelError> {
    let (mut best, mut total, mut passes, mut hits) = (Duration::MAX, Duration::ZERO, 0u32, 0usize);
    if queries.is_empty() {
        return Ok((Duration::ZERO, 0));
    }
    while passes < timing.min_passes || total < timing.min_total {
        let start = Instant::now();
        hits = pass(accel, queries, closest)?;
        let t = start.elapsed();
        best = best.min(t);
        total += t;
        passes += 1;
    }
    Ok((best, hits))
}

/// Every query's answer (in parallel, not timed).
pub fn answers(accel: &dyn Accel, queries: &[Query], closest: bool) -> Result<Vec<Answer>, AccelError> {
    queries
        .par_iter()
        .map(|q| {
            Ok(if closest {
                Answer::Closest(accel.intersect(&q.ray, 0.0, q.tmax)?)
            } else {
                Answer::Occluded(accel.occluded(&q.ray, 0.0, q.tmax)?)
            })
        })
        .collect()
}

/// Times one pass of collecting every answer: the naive loop is measured this way, so its
/// slow pass also yields the reference answers.
pub fn time_answers(accel: &dyn Accel, queries: &[Query], closest: bool) -> Result<(Duration, Vec<Answer>), AccelError> {
    let start = Instant::now();
    let a = queries
        .par_chunks(CHUNK.min(queries.len().div_ceil(rayon::current_num_threads() * 4)).max(1))
        .map(|chunk| {
            chunk
                .iter()
                .map(|q| {
                    Ok(if closest {
                        Answer::Closest(accel.intersect(&q.ray, 0.0, q.tmax)?)
                    } else {
                        Answer::Occluded(accel.occluded(&q.ray, 0.0, q.tmax)?)
                    })
                })
                .collect::<Result<Vec<_>, AccelError>>()
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((start.elapsed(), a.into_iter().flatten().collect()))
}
