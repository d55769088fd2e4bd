// Cluster-robust covariance of least-squares parameters.
#ifndef WEAVEFIT_ESTIMATOR_STATS_CLUSTER_COVARIANCE_H_
#define WEAVEFIT_ESTIMATOR_STATS_CLUSTER_COVARIANCE_H_

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <vector>

namespace weavefit {

// The bias-reduced cluster-robust covariance (CR2, Bell and McCaffrey 2002)
// of least-squares parameters with Gauss-Newton matrix H = Σ H_g and
// per-cluster scores s_g = J_gᵀ·r_g: H⁻¹·(Σ s̃_g s̃_gᵀ)·H⁻¹, where each score
// is first scaled up for the part of its own residual that its fit absorbs,
// s̃_g = (I − H_g H⁻¹)^(−1/2)·s_g (in observation space (I − P_gg)^(−1/2)·r_g,
// carried through J_gᵀ), computed as H^(1/2)·(I − M_g)^(−1/2)·H^(−1/2)·s_g
// with M_g = H^(−1/2) H_g H^(−1/2). The plain sandwich (no scaling) comes
// out short when a few clusters carry most of the information on a
// parameter; the delete-one-cluster jackknife ((I − H_g H⁻¹)^(−1)) long,
// and erratic from photograph to photograph. Directions H does not see
// (a parameter held constant) get no error.
template <int N>
inline Eigen::Matrix<double, N, N> ClusterRobustCovariance(
    const Eigen::Matrix<double, N, N>& hessian,
    const std::vector<Eigen::Matrix<double, N, N>>& cluster_hessian,
    const std::vector<Eigen::Matrix<double, N, 1>>& score) {
  using Mat = Eigen::Matrix<double, N, N>;
  using Vec = Eigen::Matrix<double, N, 1>;
  const Eigen::SelfAdjointEigenSolver<Mat> eigen(hessian);
  const double top = eigen.eigenvalues().maxCoeff();
  Vec root = Vec::Zero();
  Vec inverse_root = Vec::Zero();
  for (int k = 0; k < N; ++k) {
    const double e = eigen.eigenvalues()(k);
    if (e > 1e-12 * top) {
      root(k) = std::sqrt(e);
      inverse_root(k) = 1.0 / root(k);
    }
  }
  const Mat& v = eigen.eigenvectors();
  const Mat h_root = v * root.asDiagonal() * v.transpose();
  const Mat h_inverse_root = v * inverse_root.asDiagonal() * v.transpose();
  // A cluster that holds (nearly) all the information on a direction would
  // scale without bound: capped at 1/√(1 − 0.999).
  constexpr double kMinRemaining = 1e-3;
  Mat meat = Mat::Zero();
  for (std::size_t g = 0; g < score.size(); ++g) {
    const Mat rest = Mat::Identity() - h_inverse_root * cluster_hessian[g] * h_inverse_root;
    const Eigen::SelfAdjointEigenSolver<Mat> own(rest);
    Vec scale;
    for (int k = 0; k < N; ++k) {
      scale(k) = 1.0 / std::sqrt(std::max(own.eigenvalues()(k), kMinRemaining));
    }
    const Vec scaled = h_root * own.eigenvectors() * scale.asDiagonal() *
                       own.eigenvectors().transpose() * h_inverse_root * score[g];
    meat += scaled * scaled.transpose();
  }
  const Mat h_inverse = h_inverse_root * h_inverse_root;
  return h_inverse * meat * h_inverse;
}

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_STATS_CLUSTER_COVARIANCE_H_
