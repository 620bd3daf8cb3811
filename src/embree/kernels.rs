//! Embree's kernel sets. Embree compiles its traversal and intersection code once per vector
//! width and runs the widest the CPU has; the sets round hit distances and barycentrics
//! differently in the last bits, so an image is bit-identical only between machines that run
//! one set (`tests/path_loops.rs::each_embree_vector_width_gives_both_loops_one_image`).
//! ember names the set in each device's configuration (`isa=…`), so it knows which one runs,
//! and the set is one of the settings that change the image (`accel::AccelKind::image_key`):
//! shards and checkpoints of different sets are refused, and `--embree-kernels` picks one
//! set for every machine of a mixed cluster.

/// One of Embree's kernel sets, by the instructions it needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernels {
    /// 4 lanes: SSE4.2, the x86-64-v2 baseline.
    Sse42,
    /// 8 lanes without FMA: AVX.
    Avx,
    /// 8 lanes: AVX2 with FMA, BMI and LZCNT (x86-64-v3).
    Avx2,
    /// 16 lanes: AVX-512 F, CD, DQ, BW and VL (Embree's "AVX512", the Skylake server set).
    Avx512,
}

impl Kernels {
    /// Every set, narrowest first.
    pub const ALL: [Kernels; 4] = [Kernels::Sse42, Kernels::Avx, Kernels::Avx2, Kernels::Avx512];

    /// The set's name in Embree's configuration and in ember's settings.
    pub fn name(self) -> &'static str {
        match self {
            Kernels::Sse42 => "sse4.2",
            Kernels::Avx => "avx",
            Kernels::Avx2 => "avx2",
            Kernels::Avx512 => "avx512",
        }
    }

    /// The set named `name` ([`Kernels::name`]).
    pub fn from_name(name: &str) -> Option<Kernels> {
        Kernels::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether this CPU has the instructions the set needs.
    pub fn runs_here(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            match self {
                Kernels::Sse42 => has!("sse4.2"),
                Kernels::Avx => has!("avx"),
                Kernels::Avx2 => has!("avx2") && has!("fma") && has!("bmi1") && has!("bmi2") && has!("lzcnt"),
                Kernels::Avx512 => {
                    Kernels::Avx2.runs_here()
                        && has!("avx512f")
                        && has!("avx512cd")
                        && has!("avx512dq")
                        && has!("avx512bw")
                        && has!("avx512vl")
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self == Kernels::Sse42
        }
    }

    /// The widest set this CPU runs: the one Embree picks by itself.
    pub fn widest() -> Kernels {
        Kernels::ALL.into_iter().rev().find(|k| k.runs_here()).unwrap_or(Kernels::Sse42)
    }
}

/// The name ([`Kernels::name`]).
impl std::fmt::Display for Kernels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_the_widest_set_runs_here() {
        for k in Kernels::ALL {
            assert_eq!(Kernels::from_name(k.name()), Some(k));
        }
        assert_eq!(Kernels::from_name("avx-512"), None);
        assert!(Kernels::widest().runs_here());
        // A CPU with a set has every narrower one.
        let widest = Kernels::ALL.iter().position(|&k| k == Kernels::widest()).unwrap();
        assert!(Kernels::ALL[..=widest].iter().all(|k| k.runs_here()));
    }
}
