// The standard normal distribution's Φ and density φ together, from a
// table: the comb fit (glints/comb_fit.cc) takes them at every glint's
// nodes and every bin edge its PSF spreads a glint over, millions of times
// per photograph, where libm's erfc and exp cost three times as much.
#ifndef WEAVEFIT_ESTIMATOR_STATS_NORMAL_TABLE_H_
#define WEAVEFIT_ESTIMATOR_STATS_NORMAL_TABLE_H_

namespace weavefit {

struct NormalAt {
  double cdf = 0.0;  // Φ(z)
  double pdf = 0.0;  // φ(z)
};

// Φ(z) and φ(z) by cubic Hermite interpolation between nodes 1/64 apart
// over |z| ≤ kNormalTableReach (Φ's derivative there is φ, φ's is −z·φ):
// within 2e-10 of erfc's and exp's (normal_table_test.cc), smooth to its
// first derivative, so that difference quotients of Φ over small steps
// stay close to φ. Beyond the reach Φ is 0 or 1 and φ 0 (below 1e-15).
inline constexpr double kNormalTableReach = 8.5;
NormalAt StandardNormal(double z);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_STATS_NORMAL_TABLE_H_
