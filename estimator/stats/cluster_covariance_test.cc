// Unit tests of stats/cluster_covariance.h: the CR2 cluster-robust covariance.
#include "estimator/stats/cluster_covariance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace weavefit {
namespace {

using Mat1 = Eigen::Matrix<double, 1, 1>;
using Vec1 = Eigen::Matrix<double, 1, 1>;

// The mean of n values, each its own cluster: H = n, H_g = 1, s_g = the
// residual. CR2 is then exactly the textbook s²/n with the unbiased sample
// variance (the plain sandwich would give (n − 1)/n of it).
TEST(ClusterRobustCovariance, OfAMeanIsTheSampleVarianceOverN) {
  const std::vector<double> x = {1.0, 4.0, 2.5, -0.5, 3.0, 7.0};
  const double n = static_cast<double>(x.size());
  double mean = 0.0;
  for (double v : x) mean += v / n;
  double ss = 0.0;
  std::vector<Mat1> cluster_hessian;
  std::vector<Vec1> score;
  for (double v : x) {
    ss += (v - mean) * (v - mean);
    cluster_hessian.push_back(Mat1::Constant(1.0));
    score.push_back(Vec1::Constant(v - mean));
  }
  const Mat1 cov = ClusterRobustCovariance<1>(Mat1::Constant(n), cluster_hessian, score);
  EXPECT_NEAR(cov(0, 0), ss / (n - 1.0) / n, 1e-12);
}

// A straight line through clusters of points with noise shared within each
// cluster: the error of the intercept over many draws is what CR2 states
// (on average in variance), while the covariance that treats every point
// as independent is far too small.
TEST(ClusterRobustCovariance, SeesNoiseSharedWithinClusters) {
  using Mat = Eigen::Matrix<double, 2, 2>;
  using Vec = Eigen::Matrix<double, 2, 1>;
  constexpr int kClusters = 12;
  constexpr int kPerCluster = 8;
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  double sum_sq_error = 0.0;
  double sum_stated = 0.0;
  double sum_naive = 0.0;
  constexpr int kDraws = 2000;
  for (int d = 0; d < kDraws; ++d) {
    std::vector<double> t;
    std::vector<double> y;
    std::vector<int> cluster;
    for (int g = 0; g < kClusters; ++g) {
      const double shared = normal(rng);
      for (int k = 0; k < kPerCluster; ++k) {
        const double ti = (g * kPerCluster + k) / double(kClusters * kPerCluster) - 0.5;
        t.push_back(ti);
        y.push_back(2.0 + 3.0 * ti + shared + 0.3 * normal(rng));
        cluster.push_back(g);
      }
    }
    Mat h = Mat::Zero();
    Vec jy = Vec::Zero();
    for (std::size_t i = 0; i < t.size(); ++i) {
      const Vec j(1.0, t[i]);
      h += j * j.transpose();
      jy += j * y[i];
    }
    const Vec beta = h.ldlt().solve(jy);
    std::vector<Mat> cluster_hessian(kClusters, Mat::Zero());
    std::vector<Vec> score(kClusters, Vec::Zero());
    double rss = 0.0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      const Vec j(1.0, t[i]);
      const double r = y[i] - j.dot(beta);
      cluster_hessian[cluster[i]] += j * j.transpose();
      score[cluster[i]] += j * r;
      rss += r * r;
    }
    const Mat cov = ClusterRobustCovariance<2>(h, cluster_hessian, score);
    const Mat naive = h.inverse() * rss / (t.size() - 2.0);
    sum_sq_error += (beta(0) - 2.0) * (beta(0) - 2.0);
    sum_stated += cov(0, 0);
    sum_naive += naive(0, 0);
  }
  const double ratio = std::sqrt(sum_sq_error / sum_stated);
  EXPECT_NEAR(ratio, 1.0, 0.1);
  EXPECT_GT(std::sqrt(sum_sq_error / sum_naive), 2.0);
}

// A parameter the data do not constrain (a zero column, as for a parameter
// held constant) gets no error, and the other keeps its own.
TEST(ClusterRobustCovariance, GivesNoErrorWhereTheDataHoldNoInformation) {
  using Mat = Eigen::Matrix<double, 2, 2>;
  using Vec = Eigen::Matrix<double, 2, 1>;
  std::vector<Mat> cluster_hessian;
  std::vector<Vec> score;
  Mat h = Mat::Zero();
  const std::vector<double> r = {0.5, -1.0, 0.25, 0.25};
  for (double v : r) {
    Mat hg = Mat::Zero();
    hg(0, 0) = 1.0;
    cluster_hessian.push_back(hg);
    score.push_back(Vec(v, 0.0));
    h += hg;
  }
  const Mat cov = ClusterRobustCovariance<2>(h, cluster_hessian, score);
  EXPECT_EQ(cov(1, 1), 0.0);
  EXPECT_NEAR(cov(0, 0), (0.25 + 1.0 + 0.0625 + 0.0625) / 3.0 / 4.0, 1e-12);
}

}  // namespace
}  // namespace weavefit
